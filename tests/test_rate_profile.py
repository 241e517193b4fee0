"""The infeed's rate profile: its clock, surges drawn by seed, and the flows it shapes."""

import math

import numpy as np
import pytest

from sim.errors import InvalidInput
from sim.flow.config import MAX_ITEMS_PER_METRE, FlowConfig
from sim.flow.footprint_polygons import polygon, shift_intervals
from sim.flow.generator import generate_flow
from sim.flow.rate_profile import RateProfile, draw_surges
from sim.flow.world import WorldVariation

FIELDS = (
    "t_spawn", "y", "yaw", "type_index", "class_id", "colour", "stripe", "variant", "scale",
    "rgba", "label_rgba", "z_drop",
)  # fmt: skip
SURGE_THEN_GAP = RateProfile(((0.0, 1.0), (30.0, 2.0), (60.0, 0.0)))


def _same(a, b) -> bool:
    return len(a) == len(b) and all(
        getattr(a, name).tobytes() == getattr(b, name).tobytes() for name in FIELDS
    )


def test_clock_of_a_profile():
    profile = RateProfile(((10.0, 0.0), (20.0, 3.0), (25.0, 0.5)))
    assert profile.peak == 3.0
    assert np.array_equal(profile.factor_at([0.0, 10.0, 19.9, 20.0, 30.0]), [1, 0, 0, 3, 0.5])
    assert np.allclose(profile.cumulative(np.array([5.0, 15.0, 22.0, 29.0])), [5, 10, 16, 27])
    t = np.array([0.0, 7.5, 20.0, 21.0, 24.0, 26.0, 100.0])
    assert np.allclose(profile.inverse(profile.cumulative(t)), t)
    assert float(profile.inverse(10.0)) == 20.0  # within the gap: its end
    assert float(RateProfile(((0.0, 0.0), (5.0, 1.0))).inverse(0.0)) == 5.0
    assert math.isinf(float(SURGE_THEN_GAP.inverse(90.0)))  # a gap that never ends
    assert float(RateProfile().cumulative(12.5)) == 12.5 == float(RateProfile().inverse(12.5))
    assert RateProfile([[0, 1], [30, 2]]) == RateProfile(((0.0, 1.0), (30.0, 2.0)))


def test_combined_profiles_multiply():
    surge = RateProfile(((40.0, 3.0), (50.0, 1.0)))
    both = SURGE_THEN_GAP.combined(surge)
    t = np.linspace(0.0, 100.0, 1001)
    expected = SURGE_THEN_GAP.factor_at(t) * surge.factor_at(t)
    assert np.array_equal(both.factor_at(t), expected)
    assert both.peak == 6.0
    assert SURGE_THEN_GAP.combined(RateProfile()) == SURGE_THEN_GAP
    assert RateProfile().combined(surge) == surge


@pytest.mark.parametrize(
    "steps",
    [((1.0, 2.0), (1.0, 3.0)), ((5.0, 1.0), (2.0, 1.0)), ((-1.0, 1.0),), ((0.0, -0.5),),
     ((0.0, math.nan),), ((math.inf, 1.0),), ((0.0, 1.0, 2.0),), ((0.0, True),), 3],
)  # fmt: skip
def test_bad_profiles_are_refused_in_one_line(steps):
    with pytest.raises(InvalidInput) as error:
        RateProfile(steps)
    assert error.value.field == "infeed.profile"
    assert "\n" not in str(error.value) and "ascending" in str(error.value)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"mean_gap_s": 0.0}, "infeed.surges.mean_gap_s"),
        ({"mean_length_s": math.nan}, "infeed.surges.mean_length_s"),
        ({"factor": -1.0}, "infeed.surges.factor"),
        ({"seed": -1}, "seed"),
        ({"end_s": math.inf}, "end_s"),
    ],
)
def test_bad_surges_are_refused_in_one_line(kwargs, field):
    given = {"seed": 1, "mean_gap_s": 60.0, "mean_length_s": 10.0, "factor": 2.0, "end_s": 600.0}
    with pytest.raises(InvalidInput) as error:
        draw_surges(**{**given, **kwargs})
    assert error.value.field == field
    assert "\n" not in str(error.value)


def test_flow_refuses_a_profile_that_is_no_profile_or_brings_nothing_or_too_dense():
    with pytest.raises(InvalidInput) as error:
        FlowConfig(n_items=50, duration_s=60.0, rate_profile=((0.0, 2.0),))
    assert error.value.field == "rate_profile"
    with pytest.raises(InvalidInput, match="brings 1..100000 items") as error:
        FlowConfig(n_items=50, duration_s=60.0, rate_profile=RateProfile(((0.0, 0.0),)))
    assert error.value.field == "infeed.profile"
    n = int(0.6 * MAX_ITEMS_PER_METRE * 0.185 * 90.0)  # 60 % of the densest flat flow
    FlowConfig(n_items=n, duration_s=90.0)
    with pytest.raises(InvalidInput, match="peak x2") as error:
        FlowConfig(n_items=n, duration_s=90.0, rate_profile=SURGE_THEN_GAP)
    assert error.value.field == "n_items"


@pytest.mark.parametrize("world", [WorldVariation(), WorldVariation.uniform()])
def test_an_empty_or_flat_profile_leaves_the_flow_as_it_is(catalogue, world):
    for seed in (0, 1, 5):
        kwargs = {"n_items": 120, "duration_s": 90.0, "seed": seed, "world": world}
        today = generate_flow(FlowConfig(**kwargs), catalogue)
        empty = generate_flow(FlowConfig(**kwargs, rate_profile=RateProfile()), catalogue)
        flat = FlowConfig(**kwargs, rate_profile=RateProfile(((0.0, 1.0),)))
        assert _same(today, empty) and _same(today, generate_flow(flat, catalogue)), seed


def test_a_surge_doubles_the_arrivals_and_a_gap_stops_them(catalogue):
    per_s_before, per_s_surge = [], []
    for seed in range(4):
        config = FlowConfig(n_items=90, duration_s=90.0, seed=seed, rate_profile=SURGE_THEN_GAP)
        assert config.item_count == 90  # 30 s at x1 and 30 s at x2 of 1 item/s
        t = generate_flow(config, catalogue).t_spawn
        assert len(t) == 90
        # An item kept clear of its neighbours is dropped a little later: a few spill over.
        assert np.count_nonzero(t >= 60.0) <= 3 and t.max() < 62.0, t[t >= 60.0]
        per_s_before.append(np.count_nonzero(t < 30.0) / 30.0)
        per_s_surge.append(np.count_nonzero((t >= 30.0) & (t < 60.0)) / 30.0)
    assert np.allclose(per_s_before, 1.0, atol=0.1), per_s_before
    assert np.allclose(per_s_surge, 2.0, atol=0.15), per_s_surge


def test_a_surge_keeps_the_items_apart_on_the_belt(catalogue):
    surge = RateProfile(((20.0, 2.0), (50.0, 1.0)))
    n = int(0.5 * MAX_ITEMS_PER_METRE * 0.185 * 80.0)  # the surge at the densest belt
    config = FlowConfig(n, 80.0, seed=3, world=WorldVariation.uniform(), rate_profile=surge)
    flow = generate_flow(config, catalogue)
    v = config.belt_speed_mps
    shapes = np.array(
        [
            polygon(catalogue.types[k], -v * t, y, yaw)
            for k, t, y, yaw in zip(flow.type_index, flow.t_spawn, flow.y, flow.yaw, strict=True)
        ]
    )
    for i in range(1, len(flow)):
        lo, hi = shift_intervals(shapes[i], shapes[:i], clearance=0.0)
        assert not np.any((lo < 0) & (hi > 0)), i


def test_profiles_and_surges_are_deterministic_by_seed(catalogue):
    surges = draw_surges(3, 20.0, 5.0, 2.0, 120.0)
    assert surges == draw_surges(3, 20.0, 5.0, 2.0, 120.0)
    assert surges != draw_surges(4, 20.0, 5.0, 2.0, 120.0)
    profile = SURGE_THEN_GAP.combined(surges)

    def flow(seed):
        config = FlowConfig(n_items=40, duration_s=90.0, seed=seed, rate_profile=profile)
        return generate_flow(config, catalogue)

    assert _same(flow(2), flow(2))
    assert not _same(flow(2), flow(3))


def test_surges_have_their_mean_gap_and_length():
    mean_gap, mean_length = 100.0, 20.0
    steps = draw_surges(7, mean_gap, mean_length, 2.5, 500_000.0).steps
    starts = np.array([s for s, f in steps if f == 2.5])
    ends = np.array([s for s, f in steps if f == 1.0])
    assert len(starts) > 3000 and len(ends) == len(starts)
    assert starts[-1] < 500_000.0 and np.all(ends > starts)
    assert np.mean(ends - starts) == pytest.approx(mean_length, rel=0.1)
    gaps = np.concatenate(([starts[0]], starts[1:] - ends[:-1]))
    assert np.mean(gaps) == pytest.approx(mean_gap, rel=0.1)
