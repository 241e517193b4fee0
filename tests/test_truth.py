"""Ground-truth grid: coverage on hand-made cases, and agreement of the two entry points."""

import math

import numpy as np
import pytest

from perception.codes import (
    ALUMINIUM,
    EMPTY_CODE,
    PAPER,
    VOID,
    code_of_cell,
    observation_code,
)
from sim.flow.catalogue import Catalogue, ItemType, load_catalogue
from sim.flow.config import X_CAMERA, X_INFEED, FlowConfig
from sim.flow.coverage import outline, polygon_rect_areas
from sim.flow.footprint_polygons import contains, to_body
from sim.flow.generator import generate_flow
from sim.flow.ground_truth import cell_truth_from_poses, flow_truth, grid_truth, yaw_from_xmat
from sim.flow.ground_truth_io import load_truth, save_flow_truth
from sim.flow.world import WorldVariation

PITCH = 0.0925  # x1: 0.185 m/s x 0.5 s
CELL_AREA = 0.16 * PITCH
WHITE, RED, BROWN = 2, 4, 1  # indices into perception.codes.COLOURS


def _item(name, material, shape, pose, size):
    probs = (0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
    return ItemType(name, material, shape, pose, size, 0.01, (0.5, 0.005, 0.0001), 1.0, probs)


@pytest.fixture(scope="module")
def catalogue():
    types = (
        _item("cell_sheet", "paper", "box", "flat", (PITCH / 2, 0.08, 0.001)),
        _item("bottle", "plastic", "capsule", "lying", (0.0325, 0.07)),
        _item("can_standing", "aluminium", "cylinder", "standing", (0.033, 0.0575)),
        _item("can_lying", "aluminium", "cylinder", "lying", (0.033, 0.0575)),
        _item("strip", "paper", "box", "flat", (PITCH / 2, 0.032, 0.001)),
    )
    return Catalogue(types=types, rgba=load_catalogue().rgba)


def _one_row(catalogue, items):
    """Row 0 centred at X_CAMERA; items as (type_index, x, y, yaw, class, colour)."""
    t, x, y, yaw, cls, colour = (np.array(v) for v in zip(*items, strict=True))
    return grid_truth(x, y, yaw, t, cls, colour, catalogue, X_CAMERA, PITCH, 1)


def test_item_exactly_filling_a_cell_is_large(catalogue):
    truth = _one_row(catalogue, [(0, X_CAMERA, -0.4 + 0.16 * 2.5, 0.0, PAPER, WHITE)])
    assert truth.covered[0].tolist() == [0.0, 0.0, 1.0, 0.0, 0.0]
    assert truth.classes[0].tolist() == [VOID, VOID, PAPER, VOID, VOID]
    large_white = observation_code("large", "white")
    assert truth.codes[0].tolist() == [EMPTY_CODE, EMPTY_CODE, large_white, EMPTY_CODE, EMPTY_CODE]


def test_empty_belt_is_void_and_code_19(catalogue):
    truth = grid_truth(*[np.zeros(0)] * 6, catalogue, X_CAMERA, PITCH, 3)
    assert np.all(truth.classes == VOID) and np.all(truth.codes == EMPTY_CODE)
    assert np.all(truth.dominant == -1)


def test_standing_can_in_one_cell_is_small_and_its_area_is_right(catalogue):
    truth = _one_row(catalogue, [(2, X_CAMERA + 0.01, -0.4 + 0.08, 0.3, ALUMINIUM, RED)])
    expected = math.pi * 0.033**2 / CELL_AREA  # 0.231
    assert truth.covered[0, 0] == pytest.approx(expected, rel=1e-4)
    assert truth.codes[0, 0] == observation_code("small", "red")
    assert truth.classes[0, 0] == ALUMINIUM


def test_lying_can_in_one_cell_is_medium(catalogue):
    truth = _one_row(catalogue, [(3, X_CAMERA, 0.0, math.pi / 2, ALUMINIUM, RED)])
    assert truth.covered[0, 2] == pytest.approx(0.115 * 0.066 / CELL_AREA, rel=1e-4)  # 0.51
    assert truth.codes[0, 2] == observation_code("medium", "red")


def test_can_on_a_stripe_boundary_splits_into_two_small_halves(catalogue):
    truth = _one_row(catalogue, [(2, X_CAMERA, -0.24, 0.0, ALUMINIUM, RED)])
    half = math.pi * 0.033**2 / CELL_AREA / 2
    assert truth.covered[0, :2] == pytest.approx([half, half], rel=1e-4)
    assert truth.codes[0, :2].tolist() == [observation_code("small", "red")] * 2


def test_majority_class_and_dominant_colour_in_a_shared_cell(catalogue):
    """A 40 % paper strip and a 23 % can share a cell: paper, white, medium (63 % covered)."""
    items = [
        (4, X_CAMERA, -0.4 + 0.032 + 0.001, 0.0, PAPER, WHITE),
        (2, X_CAMERA, -0.4 + 0.16 - 0.034, 0.0, ALUMINIUM, RED),
    ]
    truth = _one_row(catalogue, items)
    assert truth.covered[0, 0] == pytest.approx(0.4 + math.pi * 0.033**2 / CELL_AREA, rel=1e-4)
    assert truth.classes[0, 0] == PAPER
    assert truth.codes[0, 0] == observation_code("medium", "white")
    assert truth.dominant[0, 0] == 0


def test_coverage_conserves_area_and_codes_match_code_of_cell():
    catalogue = load_catalogue()
    # Varied sizes and shapes, but no item over another, so every footprint's area is counted.
    world = WorldVariation(overlap_share=0.0)
    flow = generate_flow(FlowConfig(n_items=150, duration_s=90.0, seed=5, world=world), catalogue)
    x = X_CAMERA - flow.config.belt_speed_mps * flow.tau
    types = flow.item_types(catalogue)
    truth = grid_truth(
        x, flow.y, flow.yaw, flow.type_index, flow.class_id, flow.colour, catalogue,
        X_CAMERA, flow.config.row_pitch_m, 220, item_types=types,
    )  # fmt: skip
    area = sum(t.footprint_area for t in types)
    cell_area = 0.16 * flow.config.row_pitch_m
    assert truth.covered.sum() * cell_area == pytest.approx(area, rel=1e-4)
    colours = flow.colour[np.maximum(truth.dominant, 0)]
    expected = np.vectorize(lambda f, c: code_of_cell(f, ("transparent", "brown", "white",
                            "blue", "red", "green")[c]))(truth.covered, colours)  # fmt: skip
    assert np.array_equal(truth.codes, expected)
    occupied = truth.classes != VOID
    assert np.array_equal(occupied, truth.codes != EMPTY_CODE)
    # The class covering most of a cell is nearly always the dominant item's.
    assert np.mean(truth.classes[occupied] == flow.class_id[truth.dominant[occupied]]) > 0.98


def test_exact_areas_agree_with_dense_point_sampling():
    catalogue = load_catalogue()
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(60):
        item_type = catalogue.types[rng.integers(len(catalogue.types))]
        x, y, yaw = rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(-np.pi, np.pi)
        x0, y0 = rng.uniform(-0.2, 0.1, 4), rng.uniform(-0.2, 0.1, 4)
        x1, y1 = x0 + rng.uniform(0.02, 0.15, 4), y0 + 0.16
        areas = polygon_rect_areas(outline(item_type, x, y, yaw), x0, x1, y0, y1)
        for k in range(4):
            gx = x0[k] + (x1[k] - x0[k]) * (np.arange(400) + 0.5) / 400
            gy = y0[k] + (y1[k] - y0[k]) * (np.arange(400) + 0.5) / 400
            inside = contains(item_type, *to_body(gx[:, None], gy[None, :], x, y, yaw))
            rect = (x1[k] - x0[k]) * (y1[k] - y0[k])
            worst = max(worst, abs(inside.mean() - areas[k] / rect))
    assert worst < 2e-3, worst


def test_rectangle_spanning_two_cells_exactly(catalogue):
    """A cell-sized sheet shifted by half a row fills half of each of two rows."""
    x = np.array([X_CAMERA - PITCH / 2])
    truth = grid_truth(
        x, np.array([-0.4 + 0.08]), np.zeros(1), np.zeros(1, int), np.array([PAPER]),
        np.array([WHITE]), catalogue, X_CAMERA, PITCH, 2,
    )  # fmt: skip
    assert truth.covered[:, 0].tolist() == pytest.approx([0.5, 0.5], abs=1e-12)
    assert truth.covered[:, 1:].max() < 1e-12


@pytest.mark.parametrize("speed_factor", [1.0, 1.5])
def test_poses_at_observation_times_reproduce_the_flow_truth(speed_factor):
    """The sim's view (world poses at t = kT, camera band) equals the flow's row k."""
    catalogue = load_catalogue()
    flow = generate_flow(FlowConfig(80, 60.0, speed_factor, seed=2), catalogue)
    classes, codes = flow_truth(flow, catalogue)
    v, period = flow.config.belt_speed_mps, flow.config.observation_period_s
    for k in range(0, len(classes), 3):
        x = X_INFEED + v * (k * period - flow.t_spawn)
        xy = np.column_stack([x, flow.y, np.zeros(len(flow))])
        row = cell_truth_from_poses(
            xy,
            flow.yaw,
            flow.type_index,
            flow.class_id,
            flow.colour,
            catalogue,
            v * period,
            item_types=flow.item_types(catalogue),
        )
        assert np.array_equal(row[0], classes[k]) and np.array_equal(row[1], codes[k]), k


def test_item_centre_lies_in_row_round_tau_over_t():
    catalogue = load_catalogue()
    flow = generate_flow(FlowConfig(60, 60.0, 1.2, seed=9), catalogue)
    classes, _ = flow_truth(flow, catalogue)
    assert np.all(classes[flow.row, flow.stripe] == flow.class_id)


def test_yaw_from_mujoco_rotation_matrix():
    yaw = np.array([0.0, 0.7, -2.5])
    c, s = np.cos(yaw), np.sin(yaw)
    xmat = np.stack([c, -s, 0 * c, s, c, 0 * c, 0 * c, 0 * c, 1 + 0 * c], axis=1)
    assert np.allclose(yaw_from_xmat(xmat), yaw)


def test_truth_file_has_deterministic_bytes(tmp_path):
    catalogue = load_catalogue()
    config = FlowConfig(n_items=100, duration_s=90.0, seed=12)
    paths = [tmp_path / "a.npz", tmp_path / "b.npz"]
    for path in paths:
        save_flow_truth(path, generate_flow(config, catalogue), catalogue)
    assert paths[0].read_bytes() == paths[1].read_bytes()
    classes, codes = load_truth(paths[0])
    expected = flow_truth(generate_flow(config, catalogue), catalogue)
    assert np.array_equal(classes, expected[0]) and np.array_equal(codes, expected[1])
    other = tmp_path / "c.npz"
    save_flow_truth(other, generate_flow(FlowConfig(100, 90.0, seed=13), catalogue), catalogue)
    assert other.read_bytes() != paths[0].read_bytes()
