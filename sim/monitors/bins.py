"""The bins beside the belt: what lands in each, and what falls elsewhere.

Each bin is a body `bin_<class>` with a floor plate `bin_<class>_floor_plate` and walls
`bin_<class>_wall_*`; its interior is the floor plate's outline from the plate's top up to the
walls' rim (read from the compiled model, so the MJCF stays the one source). An item that comes
to rest (speed below `REST_SPEED` for `REST_TIME`) with its centre inside a bin's interior is
registered there (item id, true class, time) and parked; one that comes to rest anywhere else off
the belt, or falls below the bins' floors, is counted as dropped and parked. Items held by the cup
are never judged.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import mujoco
import numpy as np

from perception.codes import THESIS_MATERIALS, Materials
from sim.cell.held_slots import NONE_HELD, held_mask
from sim.cell.items import Items, ItemsNow

BIN_CLASSES = THESIS_MATERIALS.names
"""The thesis's bins (a catalogue's materials name others)."""
REST_SPEED = 0.02
"""Speed under which an item counts as at rest [m/s]."""
REST_TIME = 0.1
"""How long an item must stay at rest to be judged [s]."""


@dataclass(frozen=True)
class Landing:
    """An item that came to rest: in a bin (`bin` is its material) or dropped (`bin` None).

    Attributes:
        item_id: Flow id.
        true_class: Class id of the item (2, 3, ...: its material).
        bin: Material name of the bin it landed in, or None when dropped outside every bin.
        time: Simulation time it was judged [s].
        position: Where its centre was [m].
        bin_class: Class id of the bin's material, None when dropped.
    """

    item_id: int
    true_class: int
    bin: str | None
    time: float
    position: tuple[float, float, float]
    bin_class: int | None = None

    @property
    def correct(self) -> bool:
        """Landed in the bin of its own class."""
        return self.bin_class is not None and self.bin_class == self.true_class


class Bins:
    """Judges where items come to rest; keeps the records.

    Args:
        model: The cell (a bin `bin_<material>` per material: `sim.model.bin_layout`).
        items: Its items (`Cell.items`): judged and parked; the bins are static, their
            interiors read once.
        materials: The cell's materials (the thesis's by default).
        prefixes: Name prefixes of the robots whose bins these are ("" for the cell's own;
            a line's robots each have theirs: `<prefix>bin_<material>`).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        items: Items,
        materials: Materials = THESIS_MATERIALS,
        prefixes: tuple[str, ...] = ("",),
    ):
        self.pool = pool = items.pool
        self.materials = materials
        items.kinematics()
        data = items.current()
        self.interiors = {c: self._interior(model, data, c, prefixes[0]) for c in materials.names}
        # (material, interior) of every robot's bins; the first robot's are `interiors`
        self._all = [
            (c, self._interior(model, data, c, prefix)) for prefix in prefixes
            for c in materials.names
        ]  # fmt: skip
        self.lowest_z = min(lo[2] for _, (lo, _) in self._all)
        self.landed: list[Landing] = []
        self.dropped: list[Landing] = []
        self._rest_since = np.full(pool.size, np.nan)

    @staticmethod
    def _interior(model: mujoco.MjModel, data: mujoco.MjData, name: str, prefix: str = ""):
        """(low corner, high corner) of a bin's inside [m, world]."""
        plate = model.geom(f"{prefix}bin_{name}_floor_plate").id
        centre, half = data.geom_xpos[plate], model.geom_size[plate]
        rot = data.geom_xmat[plate].reshape(3, 3)
        extent = np.abs(rot) @ half  # axis-aligned half extents of the plate
        walls = [
            g
            for g in range(model.ngeom)
            if (model.geom(g).name or "").startswith(f"{prefix}bin_{name}_wall")
        ]
        rim = max(
            data.geom_xpos[g][2] + (np.abs(data.geom_xmat[g].reshape(3, 3)) @ model.geom_size[g])[2]
            for g in walls
        )
        low = np.array([centre[0] - extent[0], centre[1] - extent[1], centre[2] + extent[2]])
        high = np.array([centre[0] + extent[0], centre[1] + extent[1], rim])
        return low, high

    def bin_at(self, position) -> str | None:
        """Class name of the bin whose interior holds `position` [m], or None."""
        p = np.asarray(position)
        for name, (low, high) in self._all:
            if np.all(p >= low) and np.all(p <= high):
                return name
        return None

    def update(
        self, items: Items, held: np.ndarray = NONE_HELD, now: ItemsNow | None = None
    ) -> list[Landing]:
        """Judges the items that came to rest off the belt; parks them; returns the new records.

        The `held` slots (`sim.cell.held_slots`) are never judged; `now` (`Items.now`) is read
        here when None.
        """
        now = items.now() if now is None else now
        pool, t = self.pool, now.time
        belt = pool.belt.geometry
        free = ~held_mask(now.slots, held)
        slots, pos = now.slots[free], now.positions[free]
        self._rest_since[held] = np.nan
        fell = pos[:, 2] < self.lowest_z - 0.05
        moving = (now.speeds[free] > REST_SPEED) & ~fell
        self._rest_since[slots[moving]] = np.nan
        still = slots[~moving]
        self._rest_since[still] = np.where(
            np.isnan(self._rest_since[still]), t, self._rest_since[still]
        )
        riding = belt.on_belt(pos[:, :2]) & (pos[:, 2] > belt.top_z - 0.01)
        settled = (t - self._rest_since[slots] >= REST_TIME - 1e-9) & ~riding
        judged = ~moving & (settled | fell)
        if not judged.any():
            return []
        new = []
        for slot, p, fell_through in zip(slots[judged], pos[judged], fell[judged], strict=True):
            slot = int(slot)
            where = None if fell_through else self.bin_at(p)
            true_class = pool.item_type(slot).class_id
            bin_class = None if where is None else self.materials.id_of(where)
            xyz = cast(tuple[float, float, float], tuple(map(float, p)))
            record = Landing(int(pool.item_ids[slot]), true_class, where, t, xyz, bin_class)
            (self.landed if where else self.dropped).append(record)
            new.append(record)
            self._rest_since[slot] = np.nan
            items.park(slot)
        return new
