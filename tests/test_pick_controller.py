"""The episode's pick controller in physics: its picks leave the neighbours on the belt alone.

A flat board is picked with a standing can 5 mm from its edge and another standing can on the
way to the bin; the held board is lifted straight up over the tallest item before it moves
sideways, so both cans ride on undisturbed, upright, at the belt's speed. Axis 4 turns items
along the bins' long side without drifting into its +-pi joint limit over many picks.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from perception.codes import PAPER
from sim.cell.cell import Cell
from sim.cell.conveyor import rail_top_z
from sim.episode.pick_control import PRESS_DEPTH_M, PickController, clear_height
from tests.utils import play_pick

SPEED = 0.185


def _spawn(cell: Cell, item_id: int, name: str, x: float, y: float, yaw: float = 0.0) -> int:
    k = [t.name for t in cell.catalogue.types].index(name)
    return cell.pool.spawn(cell.data, item_id, k, x, y, yaw, (0.5, 0.5, 0.5, 1), SPEED)


def test_a_picked_board_leaves_the_standing_cans_beside_it_and_on_its_way_alone():
    cell = Cell()
    cell.reset(SPEED)
    m, d, pool = cell.model, cell.data, cell.pool
    types = {t.name: t for t in cell.catalogue.types}
    half_y, can_r = types["cardboard_flat"].size[1], types["can_330_standing"].size[0]
    board = _spawn(cell, 0, "cardboard_flat", -0.30, -0.10)  # 0.25 x 0.18 m, 4 mm thick
    beside = _spawn(cell, 1, "can_330_standing", -0.30, -0.10 + half_y + can_r + 0.005)
    on_way = _spawn(cell, 2, "can_330_standing", -0.20, -0.35)  # between the board and its bin
    mujoco.mj_step(m, d, nstep=300)  # settle
    cans = [beside, on_way]
    start = {s: d.xpos[pool.body_ids[s]].copy() for s in cans}
    t0 = d.time
    robot = PickController(cell, SPEED)
    x, y = d.xpos[pool.body_ids[board], :2]
    hit = robot.plan(float(x), float(y), PAPER)
    assert hit.feasible, hit.reason
    outcome = play_pick(robot, hit)
    assert outcome.sealed and outcome.held_to_bin and outcome.item_id == 0
    # Lifted and released with the held board's bottom over the tallest item (the cup presses
    # PRESS_DEPTH_M into the item's top).
    height = 2 * pool.item_type(board).rest_height
    for t in (hit.plan.chain.phase_start("transfer"), hit.plan.release_time):
        bottom = hit.plan.chain.at_time(t)[0][2] + PRESS_DEPTH_M - height
        assert bottom >= clear_height(cell.catalogue, rail_top_z(cell.model)) - 1e-6
    for s in cans:
        now = d.xpos[pool.body_ids[s]]
        expected = start[s] + np.array([SPEED * (d.time - t0), 0.0, 0.0])
        assert np.linalg.norm(now - expected) < 0.005, (s, now, expected)
        up = d.xmat[pool.body_ids[s]].reshape(3, 3)[2, 2]
        assert up > math.cos(0.05)  # still standing


@pytest.mark.parametrize("yaw", [1.2, -1.3])
def test_axis4_turns_stay_inside_the_joint_range(yaw):
    cell = Cell()
    cell.reset(SPEED)
    robot = PickController(cell, SPEED)
    d, pool = cell.data, cell.pool
    limit = cell.model.jnt_range[cell.model.joint("axis4_joint").id, 1]
    for i in range(8):  # the same turn again and again would wind axis 4 up by 8 x 1.2 rad
        slot = _spawn(cell, i, "paper_sheet_a4", -0.2, 0.0, yaw)
        mujoco.mj_step(cell.model, d, nstep=50)
        x, y = d.xpos[pool.body_ids[slot], :2]
        hit = robot.plan(float(x), float(y), PAPER)
        assert hit.feasible, hit.reason
        end = hit.plan.chain.at_time(hit.plan.chain.duration)[0][3]
        assert abs(end) <= math.pi / 2 + 1e-9 < limit
        # The sheet ends along the bin's long side (x): its heading turned by the plan's turn.
        turned = yaw + (end - robot.axis4)
        assert abs(math.sin(turned)) < 1e-6
        robot.axis4 = end  # as after the place
        pool.park(d, slot)
