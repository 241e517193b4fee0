"""Numbers that the Python side keeps beside the MJCF agree with the compiled scene.

The flow layer runs without MuJoCo (the HMMs' labelled grids are generated from it), so it keeps
the belt's extent and the camera line as constants; the cell reads its bins, rails and camera
from the compiled model. This test is what keeps the two from drifting apart.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from perception.camera.grid import BeltGrid
from sim.flow import config as flow_config
from sim.model.mjcf import load_scene


@pytest.fixture(scope="module")
def scene():
    model = load_scene()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def test_the_flow_belt_is_the_scene_belt(scene):
    model, _ = scene
    belt = model.geom("belt")
    x_lo, x_hi = belt.pos[0] - belt.size[0], belt.pos[0] + belt.size[0]
    assert flow_config.BELT_X_RANGE == pytest.approx((x_lo, x_hi), abs=1e-9)
    assert flow_config.BELT_HALF_WIDTH == pytest.approx(belt.size[1], abs=1e-9)
    assert belt.pos[2] + belt.size[2] == pytest.approx(0.0, abs=1e-9)  # the belt's top is z = 0


def test_the_camera_line_is_the_scene_camera(scene):
    _, data = scene
    camera_x = float(data.cam("belt_camera").xpos[0])
    assert flow_config.X_CAMERA == pytest.approx(camera_x, abs=1e-9)
    assert BeltGrid().x_line == pytest.approx(camera_x, abs=1e-9)


def test_the_infeed_is_on_the_belt(scene):
    lo, hi = flow_config.BELT_X_RANGE
    assert lo < flow_config.X_INFEED < flow_config.X_CAMERA < hi
    assert np.isclose(flow_config.X_DISCHARGE, hi)
