"""MuJoCo's warnings (`data.warning`) are counted per episode, into episodes.csv.

MuJoCo does not raise on trouble: it counts it per kind, prints the first of each kind and
carries on (or resets the data). The counter reports what is new since its last look, also
across MuJoCo's own resets; an episode whose set-points go bad counts the warnings in its row
and warns in Python; `Cell.reset` clears them for the next episode, which counts from zero.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim import config as episode_config
from sim.cell.cell import Cell
from sim.episode.loop import Episode
from sim.monitors.mj_warnings import KINDS, MujocoWarning, WarningCounter

FREE_BALL = """
<mujoco><worldbody><body><freejoint/><geom size="0.1"/></body></worldbody></mujoco>
"""


def test_kinds_follow_mujocos_warning_order():
    assert len(KINDS) == len(mujoco.MjData(mujoco.MjModel.from_xml_string(FREE_BALL)).warning)
    assert KINDS[int(mujoco.mjtWarning.mjWARN_BADQVEL)] == "badqvel"
    assert KINDS[int(mujoco.mjtWarning.mjWARN_BADCTRL)] == "badctrl"


def test_the_counter_reports_new_warnings_once_and_across_mujocos_resets():
    model = mujoco.MjModel.from_xml_string(FREE_BALL)
    data = mujoco.MjData(model)
    for _ in range(5):
        mujoco.mj_step(model, data)
    counter = WarningCounter(data)
    assert counter.update() == {}
    data.qvel[0] = np.nan  # MuJoCo counts it, resets the data and goes on
    with pytest.warns(MujocoWarning, match="badqvel x1"):
        mujoco.mj_step(model, data)
        assert counter.update() == {"badqvel": 1}
    assert counter.update() == {}  # reported once
    for _ in range(10):
        mujoco.mj_step(model, data)
    data.qvel[0] = np.inf  # the same count (1) after the second reset: still new
    with pytest.warns(MujocoWarning):
        mujoco.mj_step(model, data)
        assert counter.update() == {"badqvel": 1}
    assert counter.total == 2 and counter.by_kind["badqvel"] == 2


class _BadSetPoint:
    """A decision manager that never picks and, once, writes a NaN set-point to motor 1 (a
    faulty controller), so that MuJoCo raises its bad-control warning."""

    name = "bad-set-point"

    def __init__(self, data: mujoco.MjData):
        self.data = data
        self.done = False

    def reset(self) -> None:
        self.done = False

    def choose(self, items, robot, context):
        if not self.done:
            self.data.ctrl[0] = np.nan
            self.done = True
        return None


def test_an_episode_counts_mujoco_warnings_into_its_row_and_a_reset_clears_them():
    cell = Cell()
    config = episode_config.load(
        None, seed=3, items=4, duration_s=4.0, perception="truth", planner="fifo"
    )
    with Episode(config, cell, planner=_BadSetPoint(cell.data)) as episode:
        episode.reset()
        with pytest.warns(MujocoWarning, match="badctrl"):
            episode.run()
    row = episode.metrics.row()
    assert row["mujoco_warnings"] >= 1
    assert episode.metrics.warning_kinds.get("badctrl", 0) >= 1
    assert row["mujoco_warnings"] == sum(episode.metrics.warning_kinds.values())
    # The next episode on the same cell starts from clean counts.
    cell.reset(config.belt_speed_mps)
    assert all(cell.data.warning[i].number == 0 for i in range(len(KINDS)))
    with Episode(config.replace(seed=4), cell) as episode:
        episode.reset()
        episode.run()
    assert episode.metrics.row()["mujoco_warnings"] == 0
