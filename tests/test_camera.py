"""The belt camera: off-screen frames, the renderer's true intrinsics and pose conventions."""

from __future__ import annotations

import math

import cv2
import mujoco
import numpy as np
import pytest

from perception.camera.rectify import colour_mask
from sim.cell.camera import BeltCamera, camera_pose, marker_points, true_camera_matrix
from sim.errors import InvalidInput, ModelFileError
from sim.paths import REPO_ROOT, SCENE_XML

FIXTURE = REPO_ROOT / "tests" / "models" / "belt_camera.xml"


@pytest.fixture(scope="module")
def fixture_model():
    model = mujoco.MjModel.from_xml_path(str(FIXTURE))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def test_frames_are_rgb_uint8_and_repeatable(fixture_model):
    model, data = fixture_model
    with BeltCamera(model, 640, 360) as camera:
        first = camera.render(data)
        second = camera.render(data)
    assert first.shape == (360, 640, 3) and first.dtype == np.uint8
    assert np.array_equal(first, second)
    assert first.max() > 200  # the white item is bright
    # The render's temporary field of view is put back.
    assert model.cam_fovy[0] == pytest.approx(60.0)


def test_true_intrinsics_follow_fovy(fixture_model):
    model, _ = fixture_model
    matrix = true_camera_matrix(model, 640, 360)
    assert matrix[0, 0] == pytest.approx(180.0 / math.tan(math.radians(30.0)))
    assert matrix[0, 0] == matrix[1, 1]
    assert matrix[0, 2] == 319.5 and matrix[1, 2] == 179.5


def test_pinhole_render_matches_the_true_camera_model(fixture_model):
    """Markers land where the true intrinsics and pose project them, within 0.5 px."""
    model, data = fixture_model
    with BeltCamera(model, 1280, 720, lens=None) as camera:
        frame = camera.render(data)
        matrix = camera.camera_matrix
    world, colours = marker_points(model, data)
    rot, pos = camera_pose(model, data)
    cam = (world - pos) @ rot  # world -> OpenCV camera frame
    expected = cam[:, :2] / cam[:, 2:3] * matrix[0, 0] + matrix[:2, 2]
    for target, rgb in zip(expected, colours, strict=True):
        mask = colour_mask(frame, rgb).astype(np.uint8)
        _, _, stats, centres = cv2.connectedComponentsWithStats(mask)
        best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        assert np.linalg.norm(centres[best] - target) < 0.5


def test_the_cell_has_the_camera_and_four_markers_on_the_belt_plane():
    model = mujoco.MjModel.from_xml_path(str(SCENE_XML))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    _, pos = camera_pose(model, data)
    assert pos == pytest.approx([-1.48, 0.0, 0.75])
    world, colours = marker_points(model, data)
    assert world.shape == (4, 3) and colours.shape == (4, 3)
    assert np.all(np.abs(world[:, 1]) > 0.4)  # beside the belt
    # Four distinct hues, so each marker is identified by its colour.
    assert len({tuple(np.round(c, 2)) for c in colours}) == 4


def test_refusals(fixture_model):
    model, _ = fixture_model
    with pytest.raises(InvalidInput, match="camera resolution"):
        BeltCamera(model, 8, 8)
    with pytest.raises(ModelFileError, match="no camera named"):
        BeltCamera(model, 64, 64, name="nope")


def test_depth_map_is_registered_to_the_frame(fixture_model):
    """Depth along the optical axis: the belt 0.75 m below the camera, the 1 cm boxes closer;
    bright pixels and near pixels are the same pixels (one lens, one pixel grid)."""
    model, data = fixture_model
    with BeltCamera(model, 640, 360) as camera:
        frame, depth = camera.render_rgbd(data)
        alone = camera.render(data)
    assert depth.shape == (360, 640) and depth.dtype == np.float32
    assert np.array_equal(frame, alone)
    belt = depth[40, 320]  # upstream of the boxes, on the black belt
    assert belt == pytest.approx(0.75, abs=1e-3)
    raised = np.abs(depth - 0.74) < 1e-3  # the boxes' tops, 1 cm above the belt
    bright = frame.max(axis=2) > 100
    overlap = (raised & bright).sum() / raised.sum()
    assert raised.sum() > 1000 and overlap > 0.97
