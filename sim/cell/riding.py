"""Settled items ride the belt without contact dynamics until they near the robot.

An item that has settled on the belt (moving with it, not turning, touching nothing but the belt)
stays in that state until something else touches it: between the infeed and the robot nothing
does, so the contact solver would spend every step reproducing "moves at the belt's velocity".
Such an item is switched to riding: its geom stops colliding and its gravity is compensated, so
the free body moves on at exactly the belt's velocity, at the height and heading it settled at,
integrated by MuJoCo like any other body (the camera renders it, the truth perception reads it).
It wakes, with its contacts and gravity back, before it reaches `wake_x`, upstream of anything the
robot or a held item can touch, and from then on it is simulated in full: the pick is physics.

A rider is also woken whenever an item that is not moving with the belt (one still rolling
after its drop, one knocked about) comes within `PROXIMITY_M` of it, so riding never lets two
items pass through each other; items that move with the belt keep their distances.
`ItemRiding(enabled=False)` keeps every item in contact dynamics (the reference the tests
compare against).
"""

from __future__ import annotations

import mujoco
import numpy as np

from sim.cell.item_pool import ItemPool

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
"""A rider wakes when a loose item's bounding sphere comes this close to its own [m]."""


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
    grid = np.stack(np.meshgrid(xs, ys, zs, indexing="ij"), axis=-1).reshape(-1, 3)
    ok = reachable(grid)
    x_min = float(grid[ok, 0].min()) if np.any(ok) else 0.0
    return x_min - item_radius - WAKE_LEAD_M


class ItemRiding:
    """Which pool slots ride the belt without contact dynamics, and the switches.

    Args:
        model: The cell (its geom and body fields are switched, as the pool does).
        pool: The item pool.
        wake_x: Riders wake before their centre passes this x [m] (see `wake_line`).
        enabled: False keeps every item in contact dynamics.
    """

    def __init__(self, model: mujoco.MjModel, pool: ItemPool, wake_x: float, enabled: bool = True):
        self.model, self.pool, self.wake_x, self.enabled = model, pool, float(wake_x), enabled
        self.belt_geom = pool.belt.geom_id
        self._rider_of = np.full(pool.size, -1)  # flow item id riding in each slot, -1: none
        self._born = np.full(pool.size, np.inf)  # sim time each slot's item was first seen
        self._seen = np.full(pool.size, -1)
        self._slot_of_body = np.full(model.nbody, -1)
        self._slot_of_body[pool.body_ids] = np.arange(pool.size)
        self.rides = 0
        self.wakes = 0

    def riding(self) -> np.ndarray:
        """Slots whose item rides now."""
        return np.flatnonzero((self._rider_of >= 0) & (self._rider_of == self.pool.item_ids))

    def update(self, data: mujoco.MjData, held_slot: int | None = None) -> None:
        """Switches items to riding or back; call every few ms of simulated time."""
        if not self.enabled:
            return
        pool = self.pool
        active = pool.active_slots()
        # A slot parked or re-spawned since the last call is no longer riding.
        stale = (self._rider_of >= 0) & (self._rider_of != pool.item_ids)
        self._rider_of[stale] = -1
        new = active[self._seen[active] != pool.item_ids[active]]
        self._seen[new] = pool.item_ids[new]
        self._born[new] = data.time
        if not len(active):
            return
        riding = self._rider_of[active] >= 0
        riders, movers = active[riding], active[~riding]
        vb = pool.belt.speed
        v = data.qvel[pool.dof_adr[movers][:, None] + np.arange(6)]
        settled = (
            (np.abs(v[:, 0] - vb) <= SETTLE_SPEED_MPS)
            & (np.hypot(v[:, 1], v[:, 2]) <= SETTLE_SPEED_MPS)
            & (np.linalg.norm(v[:, 3:], axis=1) <= SETTLE_SPIN_RADPS)
        )
        # Wake the riders near the robot, and those an item not moving with the belt nears.
        rider_xy = data.xpos[pool.body_ids[riders], :2]
        wake = riders[rider_xy[:, 0] >= self.wake_x]
        loose = movers[~settled]
        if len(riders) and len(loose):
            loose_xy = data.xpos[pool.body_ids[loose], :2]
            gap = np.linalg.norm(loose_xy[:, None, :] - rider_xy[None, :, :], axis=-1)
            reach = self._radius(loose)[:, None] + self._radius(riders)[None, :] + PROXIMITY_M
            wake = np.union1d(wake, riders[np.any(gap < reach, axis=0)])
        for slot in wake:
            self._wake(int(slot))
        # Ride the settled items upstream of the robot that touch nothing but the belt.
        candidates = movers[
            settled
            & (data.time - self._born[movers] >= SETTLE_AGE_S)
            & (data.xpos[pool.body_ids[movers], 0] < self.wake_x - RIDE_MARGIN_M)
            & (movers != (-1 if held_slot is None else held_slot))
        ]
        if not len(candidates):
            return
        touching = self._touching_other(data)
        for slot in candidates:
            if slot not in touching:
                self._ride(data, int(slot), vb)

    def wake_near(self, data: mujoco.MjData, slots) -> None:
        """Wakes the riders within `PROXIMITY_M` of the items in `slots` (e.g. just dropped
        onto them)."""
        riders = self.riding()
        if not len(riders) or not len(slots):
            return
        slots = np.asarray(slots, dtype=int)
        rider_xy = data.xpos[self.pool.body_ids[riders], :2]
        near_xy = data.xpos[self.pool.body_ids[slots], :2]
        gap = np.linalg.norm(near_xy[:, None, :] - rider_xy[None, :, :], axis=-1)
        reach = self._radius(slots)[:, None] + self._radius(riders)[None, :] + PROXIMITY_M
        for slot in riders[np.any(gap < reach, axis=0)]:
            self._wake(int(slot))

    def _radius(self, slots: np.ndarray) -> np.ndarray:
        return self.model.geom_rbound[self.pool.active_geom[slots]]

    def _touching_other(self, data: mujoco.MjData) -> set[int]:
        """Slots of items in contact with anything but the belt."""
        if not data.ncon:
            return set()
        pairs = data.contact.geom[: data.ncon]
        pairs = pairs[(pairs != self.belt_geom).all(axis=1)]
        slots = self._slot_of_body[self.model.geom_bodyid[pairs.ravel()]]
        return set(slots[slots >= 0].tolist())

    def _ride(self, data: mujoco.MjData, slot: int, belt_speed: float) -> None:
        m, geom, body = self.model, self.pool.geom_id(slot), self.pool.body_ids[slot]
        m.geom_contype[geom] = m.geom_conaffinity[geom] = 0
        m.body_contype[body] = m.body_conaffinity[body] = 0
        m.body_gravcomp[body] = 1.0
        dof = self.pool.dof_adr[slot]
        data.qvel[dof : dof + 6] = (belt_speed, 0.0, 0.0, 0.0, 0.0, 0.0)
        self._rider_of[slot] = self.pool.item_ids[slot]
        self.rides += 1

    def _wake(self, slot: int) -> None:
        m, geom, body = self.model, self.pool.geom_id(slot), self.pool.body_ids[slot]
        m.geom_contype[geom] = m.geom_conaffinity[geom] = 1
        m.body_contype[body] = m.body_conaffinity[body] = 1
        m.body_gravcomp[body] = 0.0
        self._rider_of[slot] = -1
        self.wakes += 1
