"""Undistortion, camera pose from the corner markers, and the top-down belt image."""

from __future__ import annotations

import cv2
import mujoco
import numpy as np
import pytest

from perception.camera.calibration import CameraCalibration
from perception.camera.grid import BeltGrid
from perception.camera.lens import ZED_HD_LEFT
from perception.camera.pipeline import CameraPipeline
from perception.camera.rectify import BeltRectifier, TopDownRaster, locate_belt, undistort
from perception.errors import PerceptionError
from sim.cell.camera import BeltCamera, camera_pose, marker_points
from sim.cli.calibrate import DEFAULT_CALIBRATION
from sim.evaluation.camera_checks import edge_residual, grid_corner_errors
from sim.paths import REPO_ROOT, SCENE_XML

FIXTURE = REPO_ROOT / "tests" / "models" / "belt_camera.xml"
SPEEDS = (0.185, 0.222, 0.2775)  # x1, x1.2, x1.5 [m/s]


def _render(path, width, height):
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with BeltCamera(model, width, height) as camera:
        frame = camera.render(data)
        truth = camera.camera_matrix
    return model, data, frame, truth


def _calibration(width, height):
    return CameraCalibration.load(DEFAULT_CALIBRATION).scaled((width, height))


def test_undistorted_belt_edges_are_straight_within_1px():
    """The belt's black/grey edges (y = +-0.4 m) over the full frame height at 1280x720."""
    _, _, frame, _ = _render(FIXTURE, 1280, 720)
    calibration = _calibration(1280, 720)
    straight = cv2.cvtColor(undistort(frame, calibration), cv2.COLOR_RGB2GRAY)
    raw = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY)
    # Every 4th row over the full height, except the band where the fixture's items lie.
    rows = [v for v in range(20, 700, 4) if not 280 <= v <= 440]
    # Left edge (+y side) read from the belt leftwards onto the rail (stopping short of the
    # markers), right edge rightwards.
    for grey, limit in ((straight, 1.0), (raw, None)):
        left = edge_residual(grey, rows, 370, 285)
        right = edge_residual(grey, rows, 910, 995)
        if limit is None:
            assert min(left, right) > 5.0  # the raw frame's edges bow: the lens is real
        else:
            assert max(left, right) < limit, (left, right)


@pytest.mark.parametrize("speed", SPEEDS)
def test_grid_corners_lie_within_5mm_of_their_belt_positions(speed):
    """Cell corners as the pipeline places them in the frame, cast back onto the belt through
    the true camera (renderer intrinsics, applied lens, MJCF pose)."""
    model, data, frame, truth = _render(SCENE_XML, 640, 360)
    view = locate_belt(frame, _calibration(640, 360), *marker_points(model, data))
    error = grid_corner_errors(model, data, truth, ZED_HD_LEFT, view, speed)
    assert error.max() < 0.005, error.max()
    _, pos = camera_pose(model, data)
    assert np.linalg.norm(view.camera_position() - pos) < 0.01


def test_top_down_image_is_metric():
    """Item outlines in the top-down image sit where the fixture puts them (to 2 mm)."""
    model, data, frame, _ = _render(FIXTURE, 1280, 720)
    view = locate_belt(frame, _calibration(1280, 720), *marker_points(model, data))
    raster = TopDownRaster.covering((-1.63, -1.33), (-0.4, 0.4), 0.001)
    rectifier = BeltRectifier(view, raster, plane_z=0.01)
    top = rectifier.rectify(frame)
    assert top.shape == (300, 800, 3)
    for name, colour in (("item_white", (0, 1, 2)), ("item_green", (1,))):
        body = model.body(name)
        half = model.geom_size[body.geomadr[0]][:2]
        centre = data.xpos[body.id][:2]
        mask = (
            np.all(top[..., colour] > 200, axis=-1)
            if len(colour) == 3
            else ((top[..., 1] > 120) & (top[..., 0] < 100))
        )
        near = np.abs(raster.pixel_to_world(np.zeros(800), np.arange(800))[:, 1] - centre[1])
        mask[:, near > 0.1] = False
        rows, cols = np.nonzero(mask)
        xy = raster.pixel_to_world(rows, cols)
        assert np.abs(xy.mean(axis=0) - centre).max() < 0.002
        extent = 0.5 * (xy.max(axis=0) - xy.min(axis=0) + 0.001)
        assert np.abs(extent - half).max() < 0.002


def test_unusable_frames_raise_perception_errors():
    model, data, frame, _ = _render(SCENE_XML, 640, 360)
    calibration = _calibration(640, 360)
    world, colours = marker_points(model, data)
    pipeline = CameraPipeline(calibration, BeltGrid(), world, colours)
    with pytest.raises(PerceptionError, match="frame shape"):
        pipeline.observe(frame[:200], 0.185, 0.0)
    with pytest.raises(PerceptionError, match="all black"):
        pipeline.observe(np.zeros_like(frame), 0.185, 0.0)
    covered = frame.copy()
    covered[:, 420:] = 30  # a board over one side of the belt hides markers 0 and 1
    with pytest.raises(PerceptionError, match="marker 0"):
        pipeline.observe(covered, 0.185, 0.0)
    with pytest.raises(PerceptionError, match="not located"):
        pipeline.cell_corners_image(0.185)
    row = pipeline.observe(frame, 0.185, 0.0)  # the empty belt: five empty cells
    corners = pipeline.cell_corners_image(0.185)
    assert corners.shape == (5, 4, 2)
    assert np.all((corners > 0) & (corners < [640, 360]))
    assert row.codes.tolist() == [19] * 5
    with pytest.raises(PerceptionError, match="marker 0 not seen"):
        pipeline.observe(covered, 0.185, 0.5)
