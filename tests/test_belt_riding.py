"""Settled items riding the belt without contact dynamics (`sim.cell.riding`).

The same items are dropped on the cell's belt twice, once riding when settled and once in
contact dynamics all the way; where they cross the wake line and after it, both runs must agree
to a millimetre and 10 milliradians, the riders must have ridden (collisions off) and be back
in contact dynamics downstream of the wake line, and a loose item coming near a rider wakes it.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from planner.motion.kinematics import reachable_mask
from planner.motion.trajectory import Chain, Dwell, State
from sim import config as episode_config
from sim.cell.cell import Cell
from sim.cell.riding import ItemRiding
from sim.errors import InvalidInput

CHECK_S = 0.02
ROWS = 4
STRIPES_Y = (-0.26, 0.0, 0.26)


def _step(m, d, riding: ItemRiding, steps: int) -> None:
    """`steps` MuJoCo steps in one block, the riders carried on after it (as an episode does)."""
    mujoco.mj_step(m, d, nstep=steps)
    riding.carry(steps * m.opt.timestep)
    riding.sync(d)


def _drop_rows(cell: Cell, rows: int, first_type: int = 0) -> None:
    """`rows` rows of 3 items (catalogue types in turn), 0.4 m apart, handed over at belt
    speed, headings within 0.3 rad of the belt's direction (neighbours never touch)."""
    rng = np.random.default_rng(3)
    n_types, n = len(cell.catalogue.types), len(STRIPES_Y)
    for r in range(rows):
        for s, y in enumerate(STRIPES_Y):
            k = (first_type + n * r + s) % n_types
            yaw = float(rng.uniform(-0.3, 0.3)) + (math.pi if s % 2 else 0.0)
            x = -2.75 + 0.4 * r
            cell.pool.spawn(cell.data, n * r + s, k, x, y, yaw, (0.8, 0.2, 0.2, 1), cell.belt.speed)


def _run(enabled: bool, seconds: float, speed: float = 0.185):
    cell = Cell()
    cell.reset(speed)
    _drop_rows(cell, ROWS)
    riding = ItemRiding(cell.model, cell.pool, cell.wake_x, enabled=enabled)
    m, d = cell.model, cell.data
    most = 0
    steps = int(round(CHECK_S / m.opt.timestep))
    while d.time < seconds:
        _step(m, d, riding, steps)
        riding.update(d)
        most = max(most, len(riding.riding()))
    slots = cell.pool.active_slots()
    ids = cell.pool.item_ids[slots]
    pose = np.array(
        [np.r_[d.xpos[cell.pool.body_ids[s]], d.xquat[cell.pool.body_ids[s]]] for s in slots]
    )
    return cell, riding, ids, pose, most


@pytest.fixture(scope="module")
def runs():
    # Rows from x = -2.75 on: 9.5 s takes them all past the wake line (x ~ -1.03).
    return _run(True, 9.5), _run(False, 9.5)


def test_riders_end_where_contact_dynamics_puts_them(runs):
    (cell, riding, ids_r, pose_r, most), (_, _, ids_c, pose_c, _) = runs
    n = 3 * ROWS
    assert list(ids_r) == list(ids_c) and len(ids_r) == n
    assert most == n  # every item rode part of the way
    assert riding.wakes >= n and len(riding.riding()) == 0
    assert np.all(pose_r[:, 0] > cell.wake_x)
    gap = np.linalg.norm(pose_r[:, :3] - pose_c[:, :3], axis=1)
    turn = 2 * np.arccos(np.clip(np.abs(np.sum(pose_r[:, 3:] * pose_c[:, 3:], axis=1)), 0, 1))
    print(f"\nriding vs contact after 9.5 s: max {gap.max() * 1e3:.2f} mm, {turn.max():.4f} rad")
    assert gap.max() < 1e-3
    assert turn.max() < 0.01  # a lying can keeps turning slowly in contact: ~5 mrad
    # Awake again: colliding, with gravity.
    for slot in cell.pool.active_slots():
        geom = cell.pool.geom_id(int(slot))
        assert cell.model.geom_contype[geom] == 1
        assert cell.model.body_gravcomp[cell.pool.body_ids[slot]] == 0.0


def _rows_riding(speed: float, rows: int, first_type: int = 0):
    """A cell with `rows` rows dropped at belt `speed` [m/s], once all of them ride."""
    cell = Cell()
    cell.reset(speed)
    _drop_rows(cell, rows, first_type)
    riding = ItemRiding(cell.model, cell.pool, cell.wake_x)
    riders = _ride_all(cell, riding, 3 * rows, limit_s=2.0)
    assert len(riders) == 3 * rows
    return cell, riding, riders


def test_riders_move_at_the_belt_velocity_without_contacts():
    cell, riding, riders = _rows_riding(0.2775, 2, first_type=6)
    m, d = cell.model, cell.data
    adr = cell.pool.qpos_adr[riders]
    start = d.qpos[adr[:, None] + np.arange(7)].copy()
    awake_before = int(d.nv_awake)
    for _ in range(500):  # 1 s, in blocks of one and three steps (an episode's both kinds)
        _step(m, d, riding, 1)
        _step(m, d, riding, 3)
    moved = d.qpos[adr[:, None] + np.arange(7)] - start
    np.testing.assert_allclose(moved[:, 0], cell.belt.speed * 2000 * m.opt.timestep, atol=1e-9)
    np.testing.assert_allclose(moved[:, 1:], 0.0, atol=1e-12)  # no sinking, drifting, turning
    geoms = {cell.pool.geom_id(int(s)) for s in riders}
    assert not any(g in geoms for g in d.contact.geom[: d.ncon].ravel())
    # Outside MuJoCo's integrator: asleep all the way, their dofs out of the awake ones.
    bodies = cell.pool.body_ids[riders]
    assert np.all(d.body_awake[bodies] == int(mujoco.mjtSleepState.mjS_ASLEEP))
    assert int(d.nv_awake) <= awake_before - 6 * len(riders)
    # Their frames where MuJoCo's kinematics puts them (the camera draws the geoms' frames).
    carried = {"xpos": d.xpos[bodies].copy()}
    carried["geom_xpos"] = d.geom_xpos[[cell.pool.geom_id(int(s)) for s in riders]].copy()
    awake = mujoco.MjData(m)
    awake.qpos[:] = d.qpos
    m.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    try:
        mujoco.mj_kinematics(m, awake)
    finally:
        m.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    np.testing.assert_allclose(carried["xpos"], awake.xpos[bodies], atol=1e-12)
    geom_ids = [cell.pool.geom_id(int(s)) for s in riders]
    np.testing.assert_allclose(carried["geom_xpos"], awake.geom_xpos[geom_ids], atol=1e-12)


def test_riders_stand_still_asleep_until_synced():
    """`carry` only adds up the belt's time; `sync` moves the riders on by all of it at once."""
    cell, riding, riders = _rows_riding(0.185, 1)
    m, d = cell.model, cell.data
    _step(m, d, riding, 2)  # asleep now
    bodies = cell.pool.body_ids[riders]
    start = d.xpos[bodies].copy()
    for _ in range(3):
        mujoco.mj_step(m, d, nstep=7)
        riding.carry(7 * m.opt.timestep)
    assert riding.behind_s == pytest.approx(21 * m.opt.timestep, abs=1e-15)
    np.testing.assert_array_equal(d.xpos[bodies], start)  # still, and still asleep
    assert np.all(d.body_awake[bodies] == int(mujoco.mjtSleepState.mjS_ASLEEP))
    riding.sync(d)
    assert riding.behind_s == 0.0
    moved = d.xpos[bodies] - start
    np.testing.assert_allclose(moved[:, 0], 0.185 * 21 * m.opt.timestep, atol=1e-12)
    np.testing.assert_array_equal(moved[:, 1:], 0.0)
    mujoco.mj_step(m, d)  # MuJoCo finds them where their poses say: still asleep
    assert np.all(d.body_awake[bodies] == int(mujoco.mjtSleepState.mjS_ASLEEP))
    vel = riding.linear_velocity(d, riders)
    np.testing.assert_array_equal(vel, np.tile([0.185, 0.0, 0.0], (3, 1)))


def test_an_episode_syncs_the_riders_before_anything_reads_them():
    """In an episode, whenever the perception observes or a decision is due, no rider lags
    behind the belt and every rider's frame is where its pose puts it."""
    from sim.episode.loop import Episode
    from sim.episode.runner import config_cell

    settings = episode_config.load(None, perception="truth", items=40, duration_s=25.0, seed=3)
    seen = {"observations": 0, "decisions": 0, "riders": 0}

    def check(episode, what):
        riding, pool, d = episode.parts.riding, episode.cell.pool, episode.data
        assert riding.behind_s == 0.0, what
        riders = riding.riding()
        body = pool.body_ids[riders]
        # Asleep (all but those that started riding at this step): frames where poses put them.
        body = body[d.body_awake[body] == int(mujoco.mjtSleepState.mjS_ASLEEP)]
        x = d.qpos[episode.model.jnt_qposadr[episode.model.body_jntadr[body]]]
        np.testing.assert_array_equal(d.xpos[body, 0], x)
        seen[what] += 1
        seen["riders"] = max(seen["riders"], len(body))

    with Episode(settings, config_cell(settings)) as episode:
        episode.reset()
        observe = episode.perception.observe

        def watched(t):
            check(episode, "observations")
            return observe(t)

        episode.perception.observe = watched
        while episode.step_until_decision():
            check(episode, "decisions")
            episode.apply(episode.choose())
        picked = episode.metrics.row()["picked"]
    assert seen["observations"] > 40 and seen["decisions"] > 20 and seen["riders"] >= 3
    # Items wait while a neighbour could be flung by their lift (a lying bottle touching an
    # edge, a higher item within 5 mm of a sheet or over a box's corner: `pick_control`) and
    # two pass the robot meanwhile: 38 of 40.
    assert picked >= 38


def test_a_loose_item_wakes_the_rider_it_comes_near():
    cell = Cell()
    cell.reset(0.185)
    m, d, pool = cell.model, cell.data, cell.pool
    pool.spawn(d, 0, 0, -2.5, 0.0, 0.0, (1, 1, 1, 1), cell.belt.speed)
    riding = ItemRiding(m, pool, cell.wake_x)
    while not len(riding.riding()) and d.time < 1.0:
        _step(m, d, riding, 20)
        riding.update(d)
    assert list(riding.riding()) == [0]
    # A can dropped at rest just upstream: it slips on the belt, not yet moving with it.
    x = d.xpos[pool.body_ids[0], 0] - 0.25
    pool.spawn(d, 1, 9, x, 0.0, 0.0, (1, 1, 1, 1), vx=0.0)
    _step(m, d, riding, 5)
    riding.update(d)
    assert len(riding.riding()) == 0 and riding.wakes == 1


def test_the_wake_line_is_upstream_of_everything_the_robot_reaches():
    cell = Cell()
    xs = np.linspace(-1.5, 0.0, 301)
    for z in (-0.01, 0.05, 0.15, 0.25):
        pts = np.stack([xs, np.zeros_like(xs), np.full_like(xs, z)], axis=1)
        ok = reachable_mask(cell.robots[0].geometry, pts)
        assert xs[ok].min() > cell.wake_x + 0.15  # the largest item still clears it
    assert -1.48 < cell.wake_x < -0.7  # downstream of the camera, upstream of the window


def test_item_riding_is_a_validated_setting():
    assert episode_config.load(None).item_riding == "path"
    with pytest.raises(InvalidInput, match="item_riding"):
        episode_config.load(None, item_riding="kinematic")


def _ride_all(cell, riding, count, limit_s=3.0):
    m, d = cell.model, cell.data
    while len(riding.riding()) < count and d.time < limit_s:
        _step(m, d, riding, 20)
        riding.update(d)
    return riding.riding()


def test_in_window_riders_wake_only_where_the_cups_path_passes():
    """`item_riding = "path"`: riders pass the wake line still riding; a pick's planned path
    wakes the ones it passes near (the target, its touching neighbour), not the others."""
    cell = Cell()
    cell.reset(0.185)
    m, d, pool = cell.model, cell.data, cell.pool
    x0 = cell.wake_x + 0.05  # already past the wake line
    # Two items side by side (a group rides together), one 0.6 m further downstream.
    for slot, dx, y in ((0, 0.0, -0.02), (1, 0.0, 0.1), (2, 0.6, 0.0)):
        pool.spawn(d, slot, 0, x0 + dx, y, 0.0, (1, 1, 1, 1), cell.belt.speed)
    riding = ItemRiding(m, pool, cell.wake_x, in_window=True)
    riders = _ride_all(cell, riding, 3)
    assert sorted(riders.tolist()) == [0, 1, 2]
    assert d.xpos[pool.body_ids[0], 0] > cell.wake_x  # riding on inside the window
    # The cup comes down over item 0 (a dwell 2 cm above its top, for 0.2 s).
    top = d.xpos[pool.body_ids[0], 2] + m.geom_rbound[pool.geom_id(0)]
    x, y = d.xpos[pool.body_ids[0], :2]
    chain = Chain([Dwell(State([x, y, top + 0.02, 0.0], [0.185, 0, 0, 0]), 0.2)])
    woken = riding.wake_along(d, chain, cell.belt.speed, reach_xy=0.025, reach_z=0.0)
    assert woken == 2 and riding.riding().tolist() == [2]
    # A path high above every item wakes nothing.
    riding2 = ItemRiding(m, pool, cell.wake_x, in_window=True)
    riding2._rider_of[2] = pool.item_ids[2]
    high = Chain([Dwell(State([x + 0.6, 0.0, 0.6, 0.0]), 0.2)])
    assert riding2.wake_along(d, high, cell.belt.speed, reach_xy=0.025, reach_z=0.1) == 0


def test_no_item_starts_riding_in_the_window_while_a_pick_is_under_way():
    cell = Cell()
    cell.reset(0.185)
    m, d, pool = cell.model, cell.data, cell.pool
    pool.spawn(d, 0, 0, cell.wake_x + 0.1, 0.0, 0.0, (1, 1, 1, 1), cell.belt.speed)
    riding = ItemRiding(m, pool, cell.wake_x, in_window=True)
    while d.time < 1.0:
        _step(m, d, riding, 20)
        riding.update(d, robot_busy=True)
    assert len(riding.riding()) == 0
    riding.update(d, robot_busy=False)
    assert riding.riding().tolist() == [0]
