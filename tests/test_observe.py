"""Observation codes from rendered frames: colours, sizes, rows, and the score on a flow."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from perception.camera.calibration import CameraCalibration
from perception.camera.depth_footprint import FootprintMapper
from perception.camera.grid import BeltGrid
from perception.camera.observe import BELT, ColourRules, code_cells
from perception.camera.pipeline import CameraPipeline
from perception.codes import COLOURS, EMPTY_CODE, code_of_cell, observation_code
from perception.errors import PerceptionError, PerceptionInputError
from sim.cell.camera import BeltCamera, marker_points
from sim.cli.calibrate import DEFAULT_CALIBRATION
from sim.evaluation.perception_eval import evaluate_camera
from sim.flow.catalogue import load_catalogue
from sim.flow.world import WorldVariation
from sim.paths import REPO_ROOT, SCENE_XML

FIXTURE = REPO_ROOT / "tests" / "models" / "belt_camera.xml"
SIZE = (640, 360)
SPEED = 0.185
STRIPE_CENTRES = (-0.32, -0.16, 0.0, 0.16, 0.32)


def _pipeline(model, data, resolution_m=0.002):
    calibration = CameraCalibration.load(DEFAULT_CALIBRATION).scaled(SIZE)
    return CameraPipeline(calibration, BeltGrid(), *marker_points(model, data), resolution_m)


def _fixture_truth(model, data):
    """Exact covered fraction and code of each stripe's cell (one box per stripe, at t = 0)."""
    x_lo, x_hi = BeltGrid().band(SPEED)
    fractions, codes = [], []
    for name, colour in zip(
        ("item_white", "item_red", "item_green", "item_blue", "item_brown"),
        ("white", "red", "green", "blue", "brown"),
        strict=True,
    ):
        body = model.body(name)
        half = model.geom_size[body.geomadr[0]]
        cx, cy = data.xpos[body.id][:2]
        along = max(0.0, min(cx + half[0], x_hi) - max(cx - half[0], x_lo))
        fraction = along * 2 * half[1] / ((x_hi - x_lo) * 0.16)
        fractions.append(fraction)
        codes.append(code_of_cell(fraction, colour))
    return np.array(fractions), codes


@pytest.fixture(scope="module")
def fixture_frame():
    model = mujoco.MjModel.from_xml_path(str(FIXTURE))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with BeltCamera(model, *SIZE) as camera:
        frame, depth = camera.render_rgbd(data)
    return model, data, frame, depth


def test_fixture_boxes_get_their_true_codes_from_depth(fixture_frame):
    model, data, frame, depth = fixture_frame
    fractions, codes = _fixture_truth(model, data)
    assert codes == [15, 5, 18, 10, 8]
    row = _pipeline(model, data).observe(frame, SPEED, 0.0, depth)
    assert row.codes.tolist() == codes
    measured = np.array([cell.fraction for cell in row.cells])
    assert np.abs(measured - fractions).max() < 0.02
    # Item pixels are belt-plane positions inside their own cell.
    x_lo, x_hi = BeltGrid().band(SPEED)
    edges = BeltGrid().stripe_edges()
    for j, cell in enumerate(row.cells):
        assert np.all((cell.pixels[:, 0] >= x_lo) & (cell.pixels[:, 0] < x_hi))
        assert np.all((cell.pixels[:, 1] >= edges[j]) & (cell.pixels[:, 1] < edges[j + 1]))


def test_without_depth_the_boxes_look_larger(fixture_frame):
    """The belt-plane rectification sees the boxes' 1 cm tops magnified: every fraction is
    over the truth, which is why the pipeline uses the depth map when it has one."""
    model, data, frame, _ = fixture_frame
    fractions, _ = _fixture_truth(model, data)
    row = _pipeline(model, data).observe(frame, SPEED, 0.0)
    measured = np.array([cell.fraction for cell in row.cells])
    assert np.all(measured > fractions)
    assert [cell.colour for cell in row.cells] == ["white", "red", "green", "blue", "brown"]


@pytest.mark.parametrize("shape", ["bottle", "sheet"])
def test_every_catalogue_colour_is_recognised_under_the_cell_lights(shape):
    """Each of the six colours, on a lying bottle and on a flat sheet, in the cell's lighting."""
    catalogue = load_catalogue()
    rows = []
    for first in (0, 1):
        colours = COLOURS[first * 3 : first * 3 + 5] if first == 0 else COLOURS[3:] + COLOURS[:2]
        spec = mujoco.MjSpec.from_file(str(SCENE_XML))
        for y, colour in zip(STRIPE_CENTRES, colours, strict=True):
            body = spec.worldbody.add_body(pos=[-1.48, y, 0.045 if shape == "bottle" else 0.002])
            geom = {"contype": 0, "conaffinity": 0, "rgba": list(catalogue.colour_rgba(colour))}
            if shape == "bottle":
                body.add_geom(
                    type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                    size=[0.045, 0.07, 0],
                    quat=[0.7071068, 0, 0.7071068, 0],
                    **geom,
                )
            else:
                body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.06, 0.05, 0.002], **geom)
        model = spec.compile()
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        with BeltCamera(model, *SIZE) as camera:
            frame, depth = camera.render_rgbd(data)
        row = _pipeline(model, data).observe(frame, SPEED, 0.0, depth)
        rows.append(([cell.colour for cell in row.cells], list(colours)))
    for seen, placed in rows:
        assert seen == placed


def test_code_cells_on_a_synthetic_label_image():
    labels = np.full((40, 100), BELT, dtype=np.int8)
    labels[:, 0:2] = COLOURS.index("blue")  # 5 % of cell 0
    labels[:20, 20:40] = COLOURS.index("red")  # 50 % of cell 1
    labels[:, 40:58] = COLOURS.index("white")  # 90 % of cell 2 ...
    labels[:, 58:60] = COLOURS.index("green")  # ... plus a green edge: white dominates
    out = code_cells(labels, (0, 40), [(0, 20), (20, 40), (40, 60), (60, 80), (80, 100)])
    assert [c[0] for c in out] == [
        observation_code("small", "blue"),
        observation_code("medium", "red"),
        observation_code("large", "white"),
        EMPTY_CODE,
        EMPTY_CODE,
    ]
    assert out[1][1] == pytest.approx(0.5)
    assert len(out[1][3]) == 400 and out[3][2] is None


def test_refusals(fixture_frame):
    model, data, frame, depth = fixture_frame
    with pytest.raises(PerceptionInputError, match="colour_rules"):
        ColourRules(white_min_value=300)
    with pytest.raises(PerceptionInputError, match="hue bounds"):
        ColourRules(red_max_hue=100.0)
    pipeline = _pipeline(model, data)
    with pytest.raises(PerceptionInputError, match="belt speed"):
        pipeline.observe(frame, 0.9, 0.0)
    with pytest.raises(PerceptionError, match="depth map shape"):
        pipeline.observe(frame, SPEED, 0.0, depth[:10])


# The coding pipeline against the truth's codes in the uniform world: there the truth's colour
# of an item is the colour it is drawn in. In the varied world a label or a jittered shade can
# change a cell's dominant colour, which the truth (nominal colours) does not see: agreement
# 93.3 % on the short flow, 94.7 % on the 90 s flow at x1 (the camera's items are classed from
# their features there, not from the codes).
UNIFORM = WorldVariation.uniform()


def test_camera_codes_agree_with_the_truth_on_a_short_flow():
    """30 items over 15 s at x1 (the full 150-item, 90 s episodes are the slow test below)."""
    score = evaluate_camera(1.0, n_items=30, duration_s=15.0, seed=3, size=SIZE, world=UNIFORM)
    busy = score.n_cells - score.confusion[EMPTY_CODE - 1, EMPTY_CODE - 1]
    assert score.unobserved == 0
    assert busy >= 40  # the flow does put items in front of the camera
    assert score.agreement >= 0.95, score.report()


@pytest.mark.slow
@pytest.mark.parametrize("factor", [1.0, 1.2, 1.5])
def test_camera_codes_agree_with_the_truth_over_a_90s_episode(factor):
    score = evaluate_camera(factor, n_items=150, duration_s=90.0, seed=0, size=SIZE, world=UNIFORM)
    print(score.report())
    assert score.unobserved == 0
    assert score.agreement >= 0.95, score.report()


def test_footprint_mapper_refuses_bad_settings(fixture_frame):
    model, data, frame, _ = fixture_frame
    pipeline = _pipeline(model, data)
    view = pipeline.locate(frame)
    with pytest.raises(PerceptionInputError, match="rim_fraction"):
        FootprintMapper(view, pipeline.raster, rim_fraction=1.5)
    with pytest.raises(PerceptionInputError, match="min_height_m"):
        FootprintMapper(view, pipeline.raster, min_height_m=0.5, max_height_m=0.2)


def test_the_window_of_a_frame_gives_the_whole_frames_row(fixture_frame):
    """`observe_window` (a camera reading out only the window its row's band is seen in) needs
    a located belt, then gives the row `observe` gives on the whole frame; the band's window is
    a part of the whole raster's; a window of another shape or an all-black one is refused."""
    model, data, frame, depth = fixture_frame
    pipeline = _pipeline(model, data)
    with pytest.raises(PerceptionError, match="not located"):
        pipeline.observe_window(frame[:10], depth[:10], SPEED, 0.0)
    whole = pipeline.observe(frame, SPEED, 0.0, depth)
    roi = pipeline.band_mapper(SPEED).roi
    part = pipeline.observe_window(frame[roi], depth[roi], SPEED, 0.0)
    whole_roi = pipeline.mapper.roi
    assert whole_roi[0].start <= roi[0].start and roi[0].stop <= whole_roi[0].stop
    assert roi[0].stop - roi[0].start < 0.7 * (whole_roi[0].stop - whole_roi[0].start)
    assert part.codes.tolist() == whole.codes.tolist() == [15, 5, 18, 10, 8]
    for a, b in zip(part.cells, whole.cells, strict=True):
        assert np.array_equal(a.pixels, b.pixels) and np.array_equal(a.heights, b.heights)
    with pytest.raises(PerceptionError, match="window shapes"):
        pipeline.observe_window(frame[roi][:-1], depth[roi][:-1], SPEED, 0.0)
    with pytest.raises(PerceptionError, match="black"):
        pipeline.observe_window(np.zeros_like(frame[roi]), depth[roi], SPEED, 0.0)
