"""Helpers shared by the tests (fixtures live in `conftest.py`)."""

from __future__ import annotations

import mujoco

from sim.episode.pick_control import PickController, PickOutcome
from sim.paths import SCENE_XML


def scene_at_home() -> tuple[mujoco.MjModel, mujoco.MjData]:
    """A fresh (model, data) of the cell's scene, the robot at its `home` keyframe."""
    model = mujoco.MjModel.from_xml_path(str(SCENE_XML))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    return model, data


def play_pick(robot: PickController, intercept) -> PickOutcome:
    """Play one pick to its end on the robot's cell, stepping as the episode's loop does
    (set-points, step, cup, outcome), with no other after-step work."""
    model, data = robot.cell.model, robot.cell.data
    robot.start(intercept)
    while True:
        robot.before_step()
        mujoco.mj_step(model, data)
        robot.after_step()
        outcome = robot.poll()
        if outcome is not None:
            return outcome
