"""Settled items ride the belt without contact dynamics until they near the robot.

An item that has settled on the belt (moving with it, not turning, touching nothing but the belt)
stays in that state until something else touches it: between the infeed and the robot nothing
does, so the contact solver would spend every step reproducing "moves at the belt's velocity".
Such an item is switched to riding: its geom stops colliding, its gravity is compensated, and it
is carried on at the belt's velocity, at the height and heading it settled at, outside MuJoCo's
integrator. Its velocity is zeroed and MuJoCo puts its tree to sleep at the end of the next step
(sleeping is enabled for the item pool; a sleeping tree's dynamics are skipped). `carry` adds
up the belt's time after each step, and `sync` moves every rider on by the belt's travel since
the last sync: its pose, its body's frame and its geoms' frames alike, so that MuJoCo's check of
a sleeping body (its pose from `qpos` against its stored frame) finds nothing changed and leaves
it asleep. `sync` is called before anything reads or renders item poses (an episode's scheduled
checks, observations, drops, video frames and decisions); nothing in the physics touches a
rider in between. The camera renders it where it is, the truth perception reads it there. Its
`qvel` reads zero meanwhile: `linear_velocity` gives items' velocities, a rider's the belt's.
It wakes, with its contacts and gravity back, before it reaches `wake_x`, upstream of anything the
robot or a held item can touch, and from then on it is simulated in full: the pick is physics.

A rider is also woken whenever an item that is not moving with the belt (one still rolling
after its drop, one knocked about) comes within `PROXIMITY_M` of it, so riding never lets two
items pass through each other; items that move with the belt keep their distances.
`ItemRiding(enabled=False)` keeps every item in contact dynamics (the reference the tests
compare against).

With `in_window=True` (the episode's `item_riding = "path"`) riders do not wake at `wake_x`:
they ride on through the robot's window until something may touch them. The robot is the only
thing there that can, and its path is known: when a pick starts, `wake_along` wakes every rider
the planned path of the cup (and of an item hanging from it) passes near, before the cup moves;
loose items wake riders as upstream. While picks are under way (one robot's, or several of a
line's), a settled item in the window starts riding only where the rest of no pick's planned
path passes near it (`PlannedPath.passes_near`: one the cup has just woken stays in contact
dynamics until the cup has passed); an idle robot rests over a bin. A settled item that no cup
will come near therefore costs no contact dynamics at all, however long the queue in front of
the robots.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from sim.cell.held_slots import NONE_HELD, held_mask
from sim.cell.item_pool import ItemPool
from sim.cell.vectors import norms

if TYPE_CHECKING:
    from sim.cell.items import ItemsNow

SETTLE_SPEED_MPS = 1e-3
"""Largest difference from the belt's velocity of a settled item [m/s]."""
SETTLE_SPIN_RADPS = 0.02
"""Largest angular speed of a settled item [rad/s]."""
SETTLE_AGE_S = 0.2
"""Least time on the belt before an item may ride [s]."""
WAKE_LEAD_M = 0.15
"""Distance upstream of the robot's reach (enlarged by the largest item) at which riders wake,
so their contacts have settled again long before the cup arrives [m]."""
RIDE_MARGIN_M = 0.05
"""An item starts riding only this far upstream of `wake_x` (no ride-wake flicker) [m]."""
PROXIMITY_M = 0.02
"""A rider wakes when a loose item's bounding sphere comes this close to its own [m] (plus the
distance the loose item covers in two checks at its speed)."""
PATH_SAMPLE_S = 0.002
"""Time step at which a pick's planned path is checked against the riders [s]."""
PATH_MARGIN_M = 0.03
"""Margin around the cup (and an item hanging from it) within which a rider wakes [m]."""


WAKE_SCAN_PLANES = 8
"""x planes of the reach grid tested at a time by `wake_line`."""


def wake_line(reachable, item_radius: float, z_range=(-0.02, 0.3)) -> float:
    """x [m] upstream of which nothing the robot holds or moves can reach the belt's items.

    Args:
        reachable: f(points (n, 3)) -> bool (n,), the robot's reachable TCP positions.
        item_radius: Largest bounding radius of an item (one may hang from the cup) [m].
        z_range: TCP heights scanned [m].
    """
    xs = np.arange(-1.5, 0.0, 0.005)
    ys = np.linspace(-0.6, 0.6, 61)
    zs = np.linspace(z_range[0], z_range[1], 16)
    grid = np.stack(np.meshgrid(xs, ys, zs, indexing="ij"), axis=-1).reshape(len(xs), -1, 3)
    x_min = 0.0
    # The grid's x planes in ascending blocks, up to the first block holding a reachable point:
    # the least x of the whole grid's reachable points lies in it.
    for start in range(0, len(xs), WAKE_SCAN_PLANES):
        block = grid[start : start + WAKE_SCAN_PLANES].reshape(-1, 3)
        ok = reachable(block)
        if np.any(ok):
            x_min = float(block[ok, 0].min())
            break
    return x_min - item_radius - WAKE_LEAD_M


@dataclass(frozen=True, eq=False)
class PlannedPath:
    """A pick's planned cup path, sampled every `PATH_SAMPLE_S` from the pick's start.

    Attributes:
        t_start: Sim time the pick started (the path's time 0) [s].
        times: (n,) sample times from the start [s], increasing, the last the path's end.
        cup: (n, 3) the cup's centre at those times [m].
        reach_xy: How far from the cup's axis the cup or a held item reaches [m].
        reach_z: How far below the cup a held item reaches [m].
    """

    t_start: float
    times: np.ndarray
    cup: np.ndarray
    reach_xy: float
    reach_z: float

    @classmethod
    def of(cls, chain, t_start: float, reach_xy: float, reach_z: float) -> PlannedPath:
        """The path of `chain` (`duration`, `states_at(times)` giving the cup's centre first)
        played from `t_start` [s]."""
        times = np.append(np.arange(0.0, chain.duration, PATH_SAMPLE_S), chain.duration)
        cup = np.asarray(chain.states_at(times)[0], dtype=float)
        return cls(float(t_start), times, cup, float(reach_xy), float(reach_z))

    def passes_near(
        self, centre: np.ndarray, radius: np.ndarray, belt_speed: float, now: float
    ) -> np.ndarray:
        """(k,) whether the rest of the path from `now` [s] passes near items riding the belt
        at `centre` (k, 3) [m] with bounding radii `radius` (k,) [m]: the cup's centre within
        `reach_xy` + radius + `PATH_MARGIN_M` horizontally of the item (carried on at
        `belt_speed` [m/s]) while less than `reach_z` + `PATH_MARGIN_M` above its top."""
        first = int(np.searchsorted(self.times, now - self.t_start, side="right")) - 1
        first = min(max(first, 0), len(self.times) - 1)
        ahead = self.times[first:] - self.times[first]
        cup = self.cup[first:]
        reach = self.reach_xy + PATH_MARGIN_M + radius
        # Items the cup cannot come near, whichever sample: farther across the belt than
        # `reach` from every sample, or along it from every sample less the belt's travel
        # (hypot(dx, dy) is never less than |dx| or |dy|). The rest are checked sample by
        # sample.
        along = cup[:, 0] - belt_speed * ahead
        out = np.zeros(len(centre), dtype=bool)
        maybe = (
            (centre[:, 1] > cup[:, 1].min() - reach)
            & (centre[:, 1] < cup[:, 1].max() + reach)
            & (centre[:, 0] > along.min() - reach)
            & (centre[:, 0] < along.max() + reach)
        )
        if not maybe.any():
            return out
        centre, radius, reach = centre[maybe], radius[maybe], reach[maybe]
        top = centre[:, 2] + radius
        dx = cup[None, :, 0] - (centre[:, 0, None] + belt_speed * ahead[None, :])
        dy = cup[None, :, 1] - centre[:, 1, None]
        near = np.hypot(dx, dy) < reach[:, None]
        low = cup[None, :, 2] < (top + self.reach_z + PATH_MARGIN_M)[:, None]
        out[maybe] = np.any(near & low, axis=1)
        return out


class ItemRiding:
    """Which pool slots ride the belt without contact dynamics, and the switches.

    Args:
        model: The cell (its geom and body fields are switched, as the pool does).
        pool: The item pool.
        wake_x: Riders wake before their centre passes this x [m] (see `wake_line`).
        enabled: False keeps every item in contact dynamics.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        pool: ItemPool,
        wake_x: float,
        enabled: bool = True,
        in_window: bool = False,
        check_period: float = 0.02,
    ):
        self.model, self.pool, self.wake_x, self.enabled = model, pool, float(wake_x), enabled
        self.in_window = bool(in_window)
        self.check_period = float(check_period)
        self.belt_geom = pool.belt.geom_id
        self._rider_of = np.full(pool.size, -1)  # flow item id riding in each slot, -1: none
        self._born = np.full(pool.size, np.inf)  # sim time each slot's item was first seen
        self._seen = np.full(pool.size, -1)
        self._carried: tuple | None = None  # `sync`'s data, views and indices; None: stale
        self._owed = 0.0  # belt time the riders have not been carried on by yet [s]
        self.rides = 0
        self.wakes = 0

    def riding(self) -> np.ndarray:
        """Slots whose item rides now."""
        return np.flatnonzero(self._riding_mask())

    def _riding_mask(self) -> np.ndarray:
        """(pool size,) whether each slot's item rides now."""
        return (self._rider_of >= 0) & (self._rider_of == self.pool.item_ids)

    def update(
        self,
        data: mujoco.MjData,
        held: np.ndarray = NONE_HELD,
        robot_busy: bool = False,
        busy_paths: list[PlannedPath] | None = None,
        now: ItemsNow | None = None,
    ) -> None:
        """Switches items to riding or back; call every `check_period` of simulated time.
        `held`: the slots the cups hold (`sim.cell.held_slots`).
        With `in_window`, which settled items in the window may start riding: given
        `busy_paths` (the planned paths of the picks under way), those the rest of no path
        passes near; else, when `robot_busy` (a pick is under way), none. `now`: the items in
        play as read at this moment (`sim.cell.items.ItemsNow`, riders carried on), else read
        here."""
        if not self.enabled:
            return
        pool = self.pool
        active = pool.active_slots() if now is None else now.slots
        # A slot parked or re-spawned since the last call is no longer riding.
        stale = (self._rider_of >= 0) & (self._rider_of != pool.item_ids)
        if stale.any():
            self._rider_of[stale] = -1
            self._carried = None
        self.sync(data)
        new = active[self._seen[active] != pool.item_ids[active]]
        self._seen[new] = pool.item_ids[new]
        self._born[new] = data.time
        if not len(active):
            return
        if now is None:
            pos = data.xpos[pool.body_ids[active]]
            vel = data.qvel[pool.dof_adr[active][:, None] + np.arange(6)]
        else:
            pos, vel = now.positions, now.velocities
        riding = self._rider_of[active] >= 0
        moving = ~riding
        if not moving.any():  # no item to ride or to wake a rider: only the wake line
            if not self.in_window:
                self._wake_riders(data, active, pos[:, :2], active[:0], pos[:0], vel[:0], None)
            return
        movers = active[moving]
        mover_pos, v = pos[moving], vel[moving]
        settled = (
            (np.abs(v[:, 0] - pool.belt.speed) <= SETTLE_SPEED_MPS)
            & (np.hypot(v[:, 1], v[:, 2]) <= SETTLE_SPEED_MPS)
            & (norms(v[:, 3:]) <= SETTLE_SPIN_RADPS)
        )
        riders = active[riding]
        self._wake_riders(data, riders, pos[riding, :2], movers, mover_pos, v, settled)
        self._ride_settled(data, riders, movers, mover_pos, settled, held, robot_busy, busy_paths)

    def _wake_riders(self, data, riders, rider_xy, movers, mover_pos, v, settled) -> None:
        """Wake the riders near the robot (unless they ride through its window), and those an
        item not moving with the belt nears."""
        if not len(riders):
            return
        if self.in_window:
            wake = np.zeros(len(riders), dtype=bool)
        else:
            wake = rider_xy[:, 0] >= self.wake_x
        loose = movers[~settled] if len(movers) else movers
        if len(loose):
            loose_xy = mover_pos[~settled, :2]
            gap = norms(loose_xy[:, None, :] - rider_xy[None, :, :])
            reach = self._radius(loose)[:, None] + self._radius(riders)[None, :] + PROXIMITY_M
            if self.in_window:  # a knocked item moves fast: wake what it can reach by then
                vb = self.pool.belt.speed
                speed = norms(v[~settled, :3] - (vb, 0.0, 0.0))
                reach = reach + (2.0 * self.check_period) * speed[:, None]
            wake |= np.any(gap < reach, axis=0)
        for slot in riders[wake].tolist():  # ascending, as the riders
            self._wake(data, slot)

    def _ride_settled(
        self, data, riders, movers, mover_pos, settled, held, robot_busy, busy_paths
    ) -> None:
        """Ride the settled items upstream of the robot that touch nothing but the belt (with
        `in_window`, in the window too, away from the picks' paths); `riders`: the slots that
        rode at the check's start (a group of settled items touching them rides on too)."""
        upstream = mover_pos[:, 0] < self.wake_x - RIDE_MARGIN_M
        where = upstream | (self.in_window and (busy_paths is not None or not robot_busy))
        chosen = (
            settled
            & (data.time - self._born[movers] >= SETTLE_AGE_S)
            & where
            & ~held_mask(movers, held)
        )
        if not chosen.any():
            return
        candidates = movers[chosen]
        if self.in_window and busy_paths:
            # In the window: not where a pick under way will pass.
            centre = mover_pos[chosen]
            radius = self._radius(candidates)
            clear = np.ones(len(candidates), dtype=bool)
            vb, t = self.pool.belt.speed, float(data.time)
            for path in busy_paths:
                clear &= ~path.passes_near(centre, radius, vb, t)
            candidates = candidates[clear | (centre[:, 0] < self.wake_x - RIDE_MARGIN_M)]
            if not len(candidates):
                return
        calm = set(candidates.tolist()) | set(riders.tolist()) if self.in_window else set()
        touching = self._touching_other(data, calm)
        for slot in candidates.tolist():
            if slot not in touching:
                self._ride(data, slot, self.pool.belt.speed)

    def wake_near(self, data: mujoco.MjData, slots) -> None:
        """Wakes the riders within `PROXIMITY_M` of the items in `slots` (e.g. just dropped
        onto them)."""
        self.sync(data)
        riders = self.riding()
        if not len(riders) or not len(slots):
            return
        slots = np.asarray(slots, dtype=int)
        rider_xy = data.xpos[self.pool.body_ids[riders], :2]
        near_xy = data.xpos[self.pool.body_ids[slots], :2]
        gap = np.linalg.norm(near_xy[:, None, :] - rider_xy[None, :, :], axis=-1)
        reach = self._radius(slots)[:, None] + self._radius(riders)[None, :] + PROXIMITY_M
        for slot in riders[np.any(gap < reach, axis=0)]:
            self._wake(data, int(slot))

    def wake_along(
        self,
        data: mujoco.MjData,
        chain,
        belt_speed: float,
        reach_xy: float,
        reach_z: float,
    ) -> int:
        """Wakes the riders the planned path `chain` of the cup, starting now, passes near;
        returns how many (`wake_on_path` of `PlannedPath.of(chain, now, reach_xy, reach_z)`).

        Args:
            data: The cell's data (positions now).
            chain: The pick's plan from now (`states_at(times)` gives the cup's centre first).
            belt_speed: Belt speed along +x [m/s].
            reach_xy: How far from the cup's axis the cup or a held item reaches [m].
            reach_z: How far below the cup a held item reaches [m].
        """
        path = PlannedPath.of(chain, float(data.time), reach_xy, reach_z)
        return self.wake_on_path(data, path, belt_speed)

    def wake_on_path(self, data: mujoco.MjData, path: PlannedPath, belt_speed: float) -> int:
        """Wakes the riders the rest of the planned `path` passes near (`PlannedPath.
        passes_near`), and the riders touching those; returns how many."""
        self.sync(data)
        riders = self.riding()
        if not len(riders):
            return 0
        centre = data.xpos[self.pool.body_ids[riders]]
        near = path.passes_near(centre, self._radius(riders), belt_speed, float(data.time))
        woken = riders[near]
        # And the riders touching those (a group of settled items rides together).
        grown = self._within(data, riders, woken)
        while len(grown) > len(woken):
            woken = grown
            grown = self._within(data, riders, woken)
        for slot in woken:
            self._wake(data, int(slot))
        return len(woken)

    def _within(self, data: mujoco.MjData, riders: np.ndarray, slots: np.ndarray) -> np.ndarray:
        """`slots` and the `riders` whose bounding sphere comes within `PROXIMITY_M` of one of
        theirs."""
        if not len(slots):
            return slots
        body = self.pool.body_ids
        gap = np.linalg.norm(
            data.xpos[body[slots]][:, None, :] - data.xpos[body[riders]][None, :, :], axis=-1
        )
        reach = self._radius(slots)[:, None] + self._radius(riders)[None, :] + PROXIMITY_M
        return np.union1d(slots, riders[np.any(gap < reach, axis=0)])

    def _radius(self, slots: np.ndarray) -> np.ndarray:
        return self.model.geom_rbound[self.pool.active_geom[slots]]

    def _touching_other(
        self, data: mujoco.MjData, calm: set[int] | frozenset[int] = frozenset()
    ) -> set[int]:
        """Slots of items in contact with anything but the belt, or but the belt and the
        `calm` slots (settled items: a group of touching settled items rides together)."""
        if not data.ncon:
            return set()
        pairs = data.contact.geom[: data.ncon]
        pairs = pairs[(pairs != self.belt_geom).all(axis=1)]
        slots = self.pool.slot_of_body[self.model.geom_bodyid[pairs]]  # (n, 2), -1: not an item
        if calm:  # two settled items touching: they ride on together
            slots = slots[~np.isin(slots, np.fromiter(calm, dtype=int)).all(axis=1)]
        return set(np.unique(slots[slots >= 0]).tolist())

    def linear_velocity(self, data: mujoco.MjData, slots) -> np.ndarray:
        """(n, 3) linear velocities [m/s] of the items in pool `slots`: a rider's is the belt's
        (MuJoCo holds it still, asleep, its `qvel` zero), any other's MuJoCo's."""
        slots = np.asarray(slots, dtype=int)
        vel = data.qvel[self.pool.dof_adr[slots, None] + np.arange(3)].copy()
        vel[self._riding_mask()[slots]] = (self.pool.belt.speed, 0.0, 0.0)
        return vel

    @property
    def behind_s(self) -> float:
        """Belt time the riders have not been carried on by yet (0 after `sync`) [s]."""
        return self._owed

    def carry(self, duration: float) -> None:
        """The belt has run `duration` [s] more (call after every `mj_step`, with the duration
        of its block of steps); `sync` carries the riders on by its travel."""
        self._owed += duration

    def sync(self, data: mujoco.MjData) -> None:
        """Carries the riders on by the belt's travel since the last sync: their `qpos`, their
        bodies' frames and their geoms' frames move along x alike (a sleeping MuJoCo body keeps
        its frames; the inertial frames `xipos`, which nothing reads while it sleeps, MuJoCo
        recomputes when it wakes). Call before anything reads or renders item poses; the
        riders touch nothing, so the physics in between does not depend on where they are."""
        if not self._owed:
            return
        if self._carried is None or self._carried[0] is not data:
            self._carried = self._carry_indices(data)
        _, qpos, xpos, geom_xpos, qpos_x, body_x, geom_x = self._carried
        if len(qpos_x):
            dx = self.pool.belt.speed * self._owed
            x = qpos[qpos_x]
            x += dx
            qpos[qpos_x] = x
            xpos[body_x] = x  # a free body's frame is its pose
            geom_xpos[geom_x] += dx
        self._owed = 0.0

    def _carry_indices(self, data: mujoco.MjData) -> tuple:
        """`data`, flat views of its `qpos`, `xpos` and `geom_xpos`, and the riders' x in
        them."""
        m, riders = self.model, self.riding()
        body = self.pool.body_ids[riders]
        qpos_x = m.jnt_qposadr[m.body_jntadr[body]]
        count = m.body_geomnum[body]
        first = np.repeat(m.body_geomadr[body] - (np.cumsum(count) - count), count)
        geom = first + np.arange(int(count.sum()))  # every geom of every rider's body
        views = (data.qpos, data.xpos.reshape(-1), data.geom_xpos.reshape(-1))
        return (data, *views, qpos_x, 3 * body, 3 * geom)

    def _ride(self, data: mujoco.MjData, slot: int, belt_speed: float) -> None:
        m, geom, body = self.model, self.pool.geom_id(slot), self.pool.body_ids[slot]
        m.geom_contype[geom] = m.geom_conaffinity[geom] = 0
        m.body_contype[body] = m.body_conaffinity[body] = 0
        m.body_gravcomp[body] = 1.0
        dof = self.pool.dof_adr[slot]
        data.qvel[dof : dof + 6] = 0.0  # `carry` moves it
        tree = m.body_treeid[body]
        if data.tree_asleep[tree] < 0:  # awake: ready to sleep (MuJoCo sleeps it next step)
            data.tree_asleep[tree] = -1
        self._rider_of[slot] = self.pool.item_ids[slot]
        self._carried = None
        self.rides += 1

    def _wake(self, data: mujoco.MjData, slot: int) -> None:
        m, geom, body = self.model, self.pool.geom_id(slot), self.pool.body_ids[slot]
        m.geom_contype[geom] = m.geom_conaffinity[geom] = 1
        m.body_contype[body] = m.body_conaffinity[body] = 1
        m.body_gravcomp[body] = 0.0
        dof = self.pool.dof_adr[slot]
        data.qvel[dof] = self.pool.belt.speed  # moving: MuJoCo wakes it at the next step
        self._rider_of[slot] = -1
        self._carried = None
        self.wakes += 1
