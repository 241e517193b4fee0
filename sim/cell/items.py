"""The items on the belt as everything outside the cell reads them: named accessors that keep
the poses right.

A settled item riding the belt sleeps in MuJoCo and is carried on by the belt's travel lazily
(`sim.cell.riding`): its pose in `MjData` lags until the riders are brought up to date. Every
accessor here does that first (a no-op when nothing moved since), so a reader never sees a
rider where it was: the perception, the monitors, the pick controller's plan, a renderer and a
user's hook alike. Nothing outside `sim.cell` indexes `data.xpos` by an item's body, and the
riders' sync is private to this module.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from sim.cell.item_pool import ItemPool
from sim.cell.riding import ItemRiding
from sim.cell.vectors import norms


@dataclass(frozen=True, eq=False)
class ItemsNow:
    """The items in play at one moment, read once for the monitors that look at them all
    (`Items.now`): the item checks every few milliseconds of an episode.

    Attributes:
        time: Sim time [s].
        slots: Pool slots in play, ascending (n,).
        positions: Their centres [m], (n, 3).
        velocities: Their free joints' velocities, linear [m/s] then angular [rad/s], (n, 6)
            (a rider asleep reads zero).
        speeds: Their linear speeds [m/s], (n,).
    """

    time: float
    slots: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    speeds: np.ndarray

    def in_play(self, pool: ItemPool) -> ItemsNow:
        """The same moment without the items `pool` has parked since (parking moves no other
        item)."""
        keep = pool.item_ids[self.slots] >= 0
        if keep.all():
            return self
        return ItemsNow(
            self.time,
            self.slots[keep],
            self.positions[keep],
            self.velocities[keep],
            self.speeds[keep],
        )


_SIX = np.arange(6)


class Items:
    """The cell's items, read through accessors that bring the riders up to date.

    Args:
        model: The compiled cell.
        data: Its data.
        pool: Its item pool.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, pool: ItemPool):
        self._model, self._data, self.pool = model, data, pool
        self._riding: ItemRiding | None = None

    def ride(self, riding: ItemRiding | None) -> None:
        """Let `riding` carry the settled items from now on (None: every item in contact
        dynamics); an episode sets its own at reset.

        Args:
            riding: The episode's item riding, or None.
        """
        self._riding = riding

    def _bring_up_to_date(self) -> None:
        if self._riding is not None:
            self._riding.sync(self._data)

    def current(self) -> mujoco.MjData:
        """The cell's data with every item where it is now (riders carried on): what a
        renderer draws and a scheduled event reads.

        Returns:
            The cell's `MjData` (not a copy).
        """
        self._bring_up_to_date()
        return self._data

    def kinematics(self) -> None:
        """MuJoCo's kinematics of the cell as it is now (riders carried on first)."""
        self._bring_up_to_date()
        mujoco.mj_kinematics(self._model, self._data)

    @property
    def time(self) -> float:
        """The simulation's clock [s]."""
        return float(self._data.time)

    def active_slots(self) -> np.ndarray:
        """Pool slots of the items in play, ascending (n,)."""
        return self.pool.active_slots()

    def positions(self, slots: np.ndarray) -> np.ndarray:
        """Centres of the items in `slots` (n,) [m], (n, 3), a copy."""
        self._bring_up_to_date()
        return self._data.xpos[self.pool.body_ids[slots]]

    def position(self, slot: int) -> np.ndarray:
        """Centre of the item in `slot` [m], (3,) (a read-only view: copy to keep it)."""
        self._bring_up_to_date()
        return self._data.xpos[self.pool.body_ids[slot]]

    def orientation(self, slot: int) -> np.ndarray:
        """Rotation matrix of the item's body in `slot`, row-major (9,) (a view)."""
        self._bring_up_to_date()
        return self._data.xmat[self.pool.body_ids[slot]]

    def orientations(self, slots: np.ndarray) -> np.ndarray:
        """Rotation matrices of the items' bodies in `slots`, row-major (n, 9), a copy."""
        self._bring_up_to_date()
        return self._data.xmat[self.pool.body_ids[slots]]

    def geom_pose(self, slot: int) -> tuple[np.ndarray, np.ndarray]:
        """(centre [m] (3,), rotation matrix row-major (9,)) of the item's geom in `slot`."""
        self._bring_up_to_date()
        geom = self.pool.geom_id(slot)
        return self._data.geom_xpos[geom], self._data.geom_xmat[geom]

    def now(self) -> ItemsNow:
        """The items in play now, read once (riders carried on first): see `ItemsNow`."""
        self._bring_up_to_date()
        data, pool = self._data, self.pool
        slots = pool.active_slots()
        velocities = data.qvel[pool.dof_adr[slots, None] + _SIX]
        speeds = norms(velocities[:, :3])
        return ItemsNow(
            float(data.time), slots, data.xpos[pool.body_ids[slots]], velocities, speeds
        )

    def velocities(self, slots: np.ndarray) -> np.ndarray:
        """Linear velocities of the items' free joints in `slots` [m/s], (n, 3), a copy (a
        rider asleep reads zero: `ItemRiding.linear_velocity` gives the belt's)."""
        return self._data.qvel[self.pool.dof_adr[slots, None] + np.arange(3)]

    def slot_of(self, item_id: int) -> int | None:
        """Pool slot of flow item `item_id`, None when it is not in play."""
        return self.pool.slot_of(item_id)

    def park(self, slot: int) -> int:
        """Take the item in `slot` out of play (`ItemPool.park`); returns its flow id."""
        return self.pool.park(self._data, slot)

    def park_missed(self) -> list[int]:
        """Park the items past the belt's discharge end (`ItemPool.park_missed`); returns
        their flow ids."""
        self._bring_up_to_date()
        return self.pool.park_missed(self._data)

    def feed(self, flow, start: int) -> int:
        """Drop the flow's items due now, from index `start` (`ItemPool.feed`); returns the
        next index."""
        self._bring_up_to_date()
        return self.pool.feed(self._data, flow, start)

    def drop(self, flow, i: int, x: float, raise_m: float = 0.0) -> int:
        """Drop flow item `i` at `x` [m] along the belt, `raise_m` [m] higher than the flow
        drops it (`ItemPool.drop`); returns its slot."""
        self._bring_up_to_date()
        return self.pool.drop(self._data, flow, i, x, raise_m=raise_m)

    def inside_another(self, slot: int, depth_m: float) -> bool:
        """Whether the item in `slot` (posed: `kinematics` run) penetrates another item in play
        deeper than `depth_m` [m] (MuJoCo's signed distance of the two geoms,
        `mj_geomDistance`).

        Args:
            slot: The item's pool slot.
            depth_m: Penetration depth that counts [m].
        """
        self._bring_up_to_date()
        model, data, pool = self._model, self._data, self.pool
        geom = pool.geom_id(slot)
        others = pool.active_geom[pool.active_slots()]
        others = others[others != geom]
        # Only the items whose bounding spheres overlap its own can lie inside it.
        gap = np.linalg.norm(data.geom_xpos[others] - data.geom_xpos[geom], axis=1)
        near = others[gap < model.geom_rbound[geom] + model.geom_rbound[others]]
        return any(
            mujoco.mj_geomDistance(model, data, geom, int(g), depth_m, None) < -depth_m
            for g in near.tolist()
        )
