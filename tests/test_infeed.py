"""The infeed holds an item back while it would drop into an item already on the belt
(sim.episode.infeed): MuJoCo's signed distance finds the deep overlap, the held item drops clear
of the item in its way, and with the hold off it drops into it as before."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim import config
from sim.cell.cell import Cell
from sim.episode.infeed import DEEP_M
from sim.episode.loop import Episode
from sim.episode.runner import config_cell
from sim.flow.config import X_INFEED
from sim.monitors.thrown import UPSTREAM_MARGIN_M

SPEED = 0.185


@pytest.fixture(scope="module")
def cell() -> Cell:
    return Cell()


def _spawn(cell: Cell, item_id: int, name: str, x: float, y: float, yaw: float = 0.0) -> int:
    k = [t.name for t in cell.catalogue.types].index(name)
    return cell.pool.spawn(cell.data, item_id, k, x, y, yaw, (0.5, 0.5, 0.5, 1), SPEED)


def test_an_item_dropped_into_another_is_found_and_one_beside_it_is_not(cell):
    cell.reset(SPEED)
    _spawn(cell, 0, "pet_bottle_1l5", X_INFEED, 0.0)
    inside = _spawn(cell, 1, "can_330_standing", X_INFEED + 0.02, 0.01)
    mujoco.mj_kinematics(cell.model, cell.data)
    assert cell.items.inside_another(inside, DEEP_M)
    cell.pool.park(cell.data, inside)
    beside = _spawn(cell, 1, "can_330_standing", X_INFEED + 0.25, 0.0)
    mujoco.mj_kinematics(cell.model, cell.data)
    assert not cell.items.inside_another(beside, DEEP_M)


def _gap_at_drop(hold: bool) -> tuple[int, float]:
    """Item 0 of an episode moved to where item 1 is due to drop, 0.1 s before it is: (the
    infeed's holds, the signed distance [m] between the two items' geoms once item 1 is on
    the belt)."""
    cfg = config.load(None, perception="truth", items=5, duration_s=5.0, seed=0)
    cfg = cfg.replace(belt=config.Belt(infeed_hold=hold))
    ep = Episode(cfg, config_cell(cfg))
    ep.reset()
    t1 = float(ep.parts.flow.t_spawn[1])
    while ep.data.time < t1 - 0.1:
        ep._step()
    pool, data = ep.cell.pool, ep.data
    first = pool.slot_of(0)
    x = X_INFEED - ep.speed * (t1 - float(data.time))
    adr, dof = pool.qpos_adr[first], pool.dof_adr[first]
    data.qpos[adr : adr + 2] = x, ep.parts.flow.y[1]
    data.qvel[dof : dof + 6] = (ep.speed, 0.0, 0.0, 0.0, 0.0, 0.0)
    while pool.slot_of(1) is None:
        ep._step()
    mujoco.mj_kinematics(ep.model, data)
    geoms = [pool.geom_id(pool.slot_of(i)) for i in (0, 1)]
    return ep.parts.infeed.holds, mujoco.mj_geomDistance(ep.model, data, *geoms, 1.0, None)


def test_the_infeed_holds_an_item_back_until_it_drops_clear_and_off_drops_it_inside():
    holds, gap = _gap_at_drop(hold=True)
    assert holds == 1
    assert gap > -DEEP_M
    holds, gap = _gap_at_drop(hold=False)
    assert holds == 0
    assert gap < -DEEP_M  # the overlap the hold avoids
    assert np.isfinite(gap)


def test_an_item_that_waited_too_long_is_dropped_onto_what_is_in_its_way():
    """A jam at the infeed: after `MAX_HOLD_S` the item is raised until it clears the item in
    its way and lands on it, not inside it."""
    cfg = config.load(None, perception="truth", items=5, duration_s=5.0, seed=0)
    ep = Episode(cfg, config_cell(cfg))
    ep.reset()
    while ep.data.time < float(ep.parts.flow.t_spawn[1]) - 0.1:
        ep._step()
    pool, data = ep.cell.pool, ep.data
    first = pool.slot_of(0)
    adr = pool.qpos_adr[first]
    data.qpos[adr : adr + 2] = X_INFEED, ep.parts.flow.y[1]
    slot = pool.drop(data, ep.parts.flow, 1, X_INFEED)
    mujoco.mj_kinematics(ep.model, data)
    assert ep.cell.items.inside_another(slot, DEEP_M)
    ep.parts.infeed.drop_above(1, X_INFEED, slot)
    mujoco.mj_kinematics(ep.model, data)
    lifted = pool.slot_of(1)
    assert not ep.cell.items.inside_another(lifted, DEEP_M)
    z = [float(data.xpos[pool.body_ids[s], 2]) for s in (first, lifted)]
    assert z[1] > z[0]


def _upstream_travel(cell: Cell, depth_m: float) -> float:
    """A lying can (its axis across the belt, free to roll along it) set `depth_m` [m] into the
    upstream end of a lying bottle, both at the belt's speed: how far either then moves
    upstream of where it was, in the next second [m] (0: both only moved downstream)."""
    cell.reset(SPEED)
    bottle = _spawn(cell, 0, "pet_bottle_1l5", X_INFEED + 0.3, 0.0)
    lo, hi = 0.0, 0.3  # the can's distance upstream of the bottle: bisected to the overlap
    can, gap = None, 0.0
    for _ in range(40):
        if can is not None:
            cell.pool.park(cell.data, can)
        dx = 0.5 * (lo + hi)
        can = _spawn(cell, 1, "can_330_lying", X_INFEED + 0.3 - dx, 0.0, 0.5 * np.pi)
        mujoco.mj_kinematics(cell.model, cell.data)
        geoms = cell.pool.geom_id(bottle), cell.pool.geom_id(can)
        gap = mujoco.mj_geomDistance(cell.model, cell.data, *geoms, 1.0, None)
        lo, hi = (dx, hi) if gap < -depth_m else (lo, dx)
    assert gap == pytest.approx(-depth_m, abs=2e-4)
    bodies = [cell.pool.body_ids[slot] for slot in (bottle, can)]
    start = cell.data.xpos[bodies, 0].copy()
    travel = 0.0
    for _ in range(1000):
        mujoco.mj_step(cell.model, cell.data)
        travel = max(travel, float(np.max(start - cell.data.xpos[bodies, 0])))
    return travel


def test_an_overlap_the_infeed_lets_drop_does_not_carry_an_item_back_past_it(cell):
    """MuJoCo pushes two overlapping items apart the faster the deeper they overlap (about
    0.07 m/s per millimetre against the belt's 0.185 m/s here). Under `DEEP_M` a lying can
    pushed back off a bottle rolls upstream less than the margin the throw monitor allows past
    the infeed; at 1 cm (the line soak's throw) it rolls back further."""
    assert _upstream_travel(cell, 0.9 * DEEP_M) < UPSTREAM_MARGIN_M
    assert _upstream_travel(cell, 0.0099) > UPSTREAM_MARGIN_M
