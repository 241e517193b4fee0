"""A line's camera per robot (`[camera] per_robot`): each camera calibrated as the first one is,
all observed every period, their tracks fused in the one tracker."""

from __future__ import annotations

import cv2
import mujoco
import numpy as np
import pytest

from perception.camera.grid import BeltGrid
from perception.camera.lens import ZED_HD_LEFT
from sim import config as episode_config
from sim.cell.camera import (
    BeltCamera,
    camera_line,
    camera_name,
    camera_pipeline,
    camera_pose,
    marker_names,
    true_camera_matrix,
)
from sim.episode.loop import Episode
from sim.episode.runner import config_cell
from sim.errors import InvalidInput
from sim.model.line_model import LineLayout, compile_line
from sim.sensing.perception import LineCameraPerception

SIZE = (640, 360)
PIXEL_TOLERANCE = 1.0
"""Largest distance [px at 640 x 360] between where a camera's calibration and solved pose put
a belt point and where the renderer's exact camera shows it: 1 px is 2.4 mm on the belt from
0.75 m (measured: 0.34 px for every camera, the first one's included)."""
POSITION_TOLERANCE_M = 0.005
"""Largest distance between a camera's solved position and the MJCF's (measured: 2.7 mm)."""


def _config(**changes) -> episode_config.EpisodeConfig:
    data = {
        "perception": "camera",
        "robots": 2,
        "items": 30,
        "duration_s": 12.0,
        "seed": 3,
        "camera": {"per_robot": True},
    }
    return episode_config.from_dict(data | changes)


def test_each_camera_maps_known_belt_points_where_the_renderer_shows_them():
    """The committed calibration (the lens: every belt camera is the same camera model) and the
    pose each camera's pipeline solves from its own four markers on its first frame, as the
    single cell's camera is used: belt points near each camera line project within
    `PIXEL_TOLERANCE` of their true pixels."""
    layout = LineLayout(3, cameras_per_robot=True)
    model = compile_line(layout)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    for prefix, x_line in zip(layout.camera_prefixes, layout.camera_lines_m, strict=True):
        name = camera_name(prefix)
        assert camera_line(model, name) == pytest.approx(x_line)
        with BeltCamera(model, *SIZE, name=name, samples=0) as camera:
            frame = camera.render(data)
        grid = BeltGrid(x_line=x_line)
        view = camera_pipeline(model, data, SIZE, grid, markers=marker_names(prefix)).locate(frame)
        rot, position = camera_pose(model, data, name)
        assert np.linalg.norm(view.camera_position() - position) < POSITION_TOLERANCE_M
        belt = np.array(
            [[x_line + dx, y, 0.0] for dx in (-0.1, 0.0, 0.1) for y in (-0.35, 0, 0.35)]
        )
        rvec, _ = cv2.Rodrigues(rot.T)
        truth, _ = cv2.projectPoints(
            belt,
            rvec,
            -rot.T @ position,
            true_camera_matrix(model, *SIZE, name),
            ZED_HD_LEFT.dist_coeffs(),
        )
        error = np.linalg.norm(view.project(belt) - truth.reshape(-1, 2), axis=1)
        assert error.max() < PIXEL_TOLERANCE, (name, error.max())


def test_a_two_robot_episode_with_a_camera_each_runs_clean():
    """Both cameras observe every period, the second one's detections are fused with the first
    one's tracks (one track per item in the attribution), and MuJoCo warns of nothing."""
    config = _config()
    cell = config_cell(config)
    assert mujoco.mj_name2id(cell.model, mujoco.mjtObj.mjOBJ_CAMERA, "r1_belt_camera") >= 0
    with Episode(config, cell) as episode:
        episode.reset()
        perception = episode.perception
        assert isinstance(perception, LineCameraPerception)
        assert [c.x_line for c in perception.cameras] == pytest.approx([-1.48, 0.9])
        seen, made = [0, 0], [0, 0]  # detections and new tracks by camera
        update = episode.tracker.update

        def watched(detections):
            created = update(detections)
            for det in detections:
                seen[det.camera] += 1
            for track in created:
                made[track.camera] += 1
            return created

        episode.tracker.update = watched
        episode.run()
        row = episode.metrics.row()
    print(f"detections by camera {seen}, new tracks {made}, {row['picked']} picked")
    assert row["mujoco_warnings"] == 0
    assert perception.cameras[1].rows == perception.cameras[0].rows > 0
    assert perception.unobserved == 0
    assert min(seen) > 0 and row["picked"] > 0.5 * row["entered"]
    # Most items the second camera saw were tracked already: fused, not tracked twice.
    assert made[1] < 0.5 * seen[1]


def test_one_camera_by_default_and_a_cell_without_the_cameras_is_refused():
    config = _config(camera={"per_robot": False})
    cell = config_cell(config)
    assert mujoco.mj_name2id(cell.model, mujoco.mjtObj.mjOBJ_CAMERA, "r1_belt_camera") < 0
    with pytest.raises(InvalidInput, match="camera.per_robot"):
        Episode(_config(), cell).reset()
    truth = config_cell(_config(perception="truth"))
    assert truth is config_cell(_config(perception="truth", camera={"per_robot": False}))
