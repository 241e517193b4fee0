"""The flow generator: configured priors and transitions, determinism, refusals, no overlaps."""

import numpy as np
import pytest
from scipy import stats

from sim.errors import InvalidInput
from sim.flow.config import (
    BELT_HALF_WIDTH,
    MAX_ITEMS_PER_METRE,
    X_CAMERA,
    X_INFEED,
    FlowConfig,
    stripe_of,
)
from sim.flow.footprint_polygons import polygon, shift_intervals
from sim.flow.generator import POOL_CAPACITY_REQUIRED, generate_flow, max_items_on_belt
from sim.flow.world import WorldVariation

N_LARGE = 20_000
STRIPES = (0.10, 0.25, 0.30, 0.20, 0.15)
TRANSITIONS = ((0.6, 0.3, 0.1), (0.2, 0.5, 0.3), (0.25, 0.25, 0.5))
TOLERANCE = 0.02
P_MIN = 1e-3


@pytest.fixture(scope="module")
def large_flow(catalogue):
    config = FlowConfig(
        n_items=N_LARGE,
        duration_s=12_000.0,
        stripe_priors=STRIPES,
        transitions=TRANSITIONS,
        seed=7,
    )
    return generate_flow(config, catalogue)


def test_stripe_frequencies_match_priors(large_flow):
    counts = np.bincount(large_flow.stripe, minlength=5)
    expected = np.asarray(STRIPES) * N_LARGE
    p_value = stats.chisquare(counts, expected).pvalue
    deviation = np.abs(counts / N_LARGE - STRIPES).max()
    assert deviation < TOLERANCE, deviation
    assert p_value > P_MIN, p_value
    assert np.array_equal(stripe_of(large_flow.y), large_flow.stripe)


def test_class_transitions_within_stripes_match_matrix(large_flow):
    counts = np.zeros((3, 3))
    for stripe in range(5):
        classes = large_flow.class_id[large_flow.stripe == stripe] - 2
        np.add.at(counts, (classes[:-1], classes[1:]), 1)
    assert counts.sum() == N_LARGE - 5
    for row, probs in zip(counts, TRANSITIONS, strict=True):
        deviation = np.abs(row / row.sum() - probs).max()
        p_value = stats.chisquare(row, np.asarray(probs) * row.sum()).pvalue
        assert deviation < TOLERANCE, (row, deviation)
        assert p_value > P_MIN, (row, p_value)


def test_types_and_colours_follow_the_catalogue(large_flow, catalogue):
    for material, class_id in (("paper", 2), ("plastic", 3), ("aluminium", 4)):
        group = catalogue.of_material(material)
        of_class = large_flow.type_index[large_flow.class_id == class_id]
        assert set(np.unique(of_class)) <= set(group)
        weights = np.array([catalogue.types[i].weight for i in group])
        counts = np.array([(of_class == i).sum() for i in group])
        expected = weights / weights.sum() * len(of_class)
        assert stats.chisquare(counts, expected).pvalue > P_MIN
    for index, item_type in enumerate(catalogue.types):
        colours = large_flow.colour[large_flow.type_index == index]
        assert np.all(np.asarray(item_type.colour_probs)[colours] > 0)


def test_same_seed_same_bytes_other_seed_other_flow(catalogue):
    config = FlowConfig(n_items=300, duration_s=150.0, seed=3)
    a, b = generate_flow(config, catalogue), generate_flow(config, catalogue)
    c = generate_flow(FlowConfig(n_items=300, duration_s=150.0, seed=4), catalogue)
    fields = ("t_spawn", "y", "yaw", "type_index", "class_id", "colour", "stripe")
    for name in fields:
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name
    assert any(getattr(a, name).tobytes() != getattr(c, name).tobytes() for name in fields)


@pytest.mark.parametrize("speed_factor", [1.0, 1.5])
def test_densest_flow_never_overlaps_and_stays_on_the_belt(catalogue, speed_factor):
    duration = 120.0
    n = int(MAX_ITEMS_PER_METRE * 0.185 * speed_factor * duration)
    # The uniform world keeps items apart; the varied one is tests/test_world_variation.py's.
    config = FlowConfig(n, duration, speed_factor, seed=11, world=WorldVariation.uniform())
    flow = generate_flow(config, catalogue)
    v = flow.config.belt_speed_mps
    shapes = np.array(
        [
            polygon(catalogue.types[k], -v * t, y, yaw)
            for k, t, y, yaw in zip(flow.type_index, flow.t_spawn, flow.y, flow.yaw, strict=True)
        ]
    )
    assert np.all(np.abs(shapes[..., 1]) <= BELT_HALF_WIDTH + 1e-9)
    for i in range(1, len(flow)):
        lo, hi = shift_intervals(shapes[i], shapes[:i], clearance=0.0)
        assert not np.any((lo < 0) & (hi > 0)), i
    assert np.all(np.diff(flow.t_spawn) >= 0)
    assert max_items_on_belt(flow) <= POOL_CAPACITY_REQUIRED


def test_time_and_row_convention(catalogue):
    flow = generate_flow(FlowConfig(n_items=50, duration_s=60.0, speed_factor=1.2), catalogue)
    v = 0.185 * 1.2
    assert np.allclose(flow.tau, flow.t_spawn + (X_CAMERA - X_INFEED) / v)
    assert np.array_equal(flow.row, np.rint(flow.tau / 0.5).astype(int))
    t = float(flow.tau[10])
    assert flow.x_at(t)[10] == pytest.approx(X_CAMERA)
    assert 10 in flow.on_belt(t)
    spawn = flow.spawn(10)
    assert (spawn.item_id, spawn.t, spawn.class_id) == (10, flow.t_spawn[10], flow.class_id[10])


def test_too_dense_a_flow_is_refused(catalogue):
    with pytest.raises(InvalidInput, match="items per metre") as error:
        FlowConfig(n_items=400, duration_s=90.0)
    assert error.value.field == "n_items"
    FlowConfig(n_items=400, duration_s=190.0)
    config = FlowConfig(n_items=150, duration_s=90.0)
    with pytest.raises(InvalidInput, match="at most 10 items on the belt"):
        generate_flow(config, catalogue, pool_size=10)


@pytest.mark.parametrize("factor", [0.5, 0.7, 1.51, 2.0])
def test_speed_outside_the_conveyor_range_is_refused(factor):
    with pytest.raises(InvalidInput, match=r"0\.135\.\.0\.277 m/s") as error:
        FlowConfig(speed_factor=factor)
    assert error.value.field == "speed_factor"


@pytest.mark.parametrize("factor", [0.73, 1.0, 1.2, 1.5])
def test_speeds_inside_the_range_are_accepted(factor):
    assert FlowConfig(speed_factor=factor).belt_speed_mps == pytest.approx(0.185 * factor)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("stripe_priors", (0.2, 0.2, 0.2, 0.2)),
        ("stripe_priors", (0.5, 0.5, 0.5, -0.5, 0.0)),
        ("transitions", ((0.5, 0.5, 0.0), (0.5, 0.5, 0.0), (0.5, 0.6, 0.0))),
        ("class_priors", (1.0, 0.0)),
        ("n_items", 0),
        ("seed", -1),
        ("duration_s", 0.0),
    ],
)
def test_bad_settings_are_refused_by_name(field, value):
    with pytest.raises(InvalidInput) as error:
        FlowConfig(**{field: value})
    assert error.value.field == field
