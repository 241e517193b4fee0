"""An idle robot sleeps in MuJoCo and wakes for its next pick (`sim.cell.idle_sleep`).

Asleep, it stands exactly still with its loop closed; a pick wakes it and plays as awake; its
motors' holding power is metered as if awake; disabled, MuJoCo never lets it sleep.
"""

from __future__ import annotations

import mujoco
import numpy as np

from perception.codes import PAPER
from sim.cell.cell import Cell
from sim.cell.idle_sleep import COMPILED_POLICY, IdleSleep, robot_trees
from sim.cell.robot import loop_closure_error, tcp_position
from sim.episode.pick_control import PickController
from sim.monitors.energy import EnergyMeter
from tests.utils import play_pick

SPEED = 0.185


def _settled_cell() -> Cell:
    cell = Cell()
    cell.reset(SPEED)
    return cell


def test_the_compiled_robot_never_sleeps_and_disabled_keeps_it_so():
    cell = _settled_cell()
    trees = robot_trees(cell.model)
    assert len(trees) == 4  # three arms with their rods, the platform with axis 4 and the cup
    assert np.all(cell.model.tree_sleep_policy[trees] == COMPILED_POLICY)
    IdleSleep(cell.model, cell.data, enabled=True)
    sleep = IdleSleep(cell.model, cell.data, enabled=False)  # restores the compiled policy
    assert np.all(cell.model.tree_sleep_policy[trees] == COMPILED_POLICY)
    mujoco.mj_step(cell.model, cell.data, nstep=500)
    assert not sleep.asleep()


def test_an_idle_robot_falls_asleep_stands_still_and_wakes_for_a_pick():
    cell = _settled_cell()
    m, d = cell.model, cell.data
    board = cell.pool.spawn(d, 0, 3, -0.35, -0.10, 0.0, (0.5, 0.5, 0.5, 1), SPEED)  # cardboard
    robot = PickController(cell, SPEED, idle_sleep=True)
    mujoco.mj_step(m, d, nstep=200)
    assert robot.sleep.asleep()
    tcp = tcp_position(m, d).copy()
    mujoco.mj_step(m, d, nstep=100)
    assert robot.sleep.asleep()
    np.testing.assert_array_equal(tcp_position(m, d), tcp)  # asleep: not a bit moves
    assert loop_closure_error(m, d) < 1e-4
    x, y = (float(v) for v in d.xpos[cell.pool.body_ids[board], :2])
    hit = robot.plan(x, y, PAPER)
    assert hit.feasible, hit.reason
    outcome = play_pick(robot, hit)  # the start wakes it; awake through the whole pick
    assert outcome.sealed and outcome.held_to_bin and outcome.item_id == 0
    assert loop_closure_error(m, d) < 1e-4
    mujoco.mj_step(m, d, nstep=300)
    assert robot.sleep.asleep()  # idle again, asleep again


def test_a_sleeping_robot_is_metered_holding_still_as_when_awake():
    """Over 2 s of rest the electrical energy (the copper loss of the holding torques) is
    the same within 2 % asleep and awake (the robot falls asleep 40 ms after the reset, its
    torques then still 1 % above where they settle); the mechanical energy is not more."""
    readings = []
    for enabled in (False, True):
        cell = _settled_cell()
        sleep = IdleSleep(cell.model, cell.data, enabled=enabled)
        meter = EnergyMeter(cell.model, cell.data, asleep_tree=sleep.tree if enabled else None)
        dt = float(cell.model.opt.timestep)
        for _ in range(2000):
            mujoco.mj_step(cell.model, cell.data)
            meter.add(dt)
        assert sleep.asleep() == enabled
        readings.append(meter.reading())
    (mech_awake, elec_awake), (mech_asleep, elec_asleep) = readings
    assert elec_awake > 1.0  # holding against gravity costs copper loss
    assert abs(elec_asleep - elec_awake) < 0.02 * elec_awake
    assert mech_asleep <= mech_awake
