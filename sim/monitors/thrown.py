"""Items thrown off the belt: what a plant would stop the line for.

An item is *thrown off* when, not held by the cup and not let go by it over a bin,

- its centre leaves the belt's top area sideways: beyond the outer face of a side rail;
- or upstream: more than `UPSTREAM_MARGIN_M` upstream of the infeed's drop line (the belt only
  ever carries items downstream; past its discharge end they are missed, not thrown);
- or it moves faster than `THROW_SPEED_MPS` anywhere: on the belt items move at its speed
  (at most 0.28 m/s), so only a blow from the cup or a held item makes them that fast.

Items the cup released over a bin fall into it at up to 3 m/s and are never judged here, nor
is the held item. An item counts once per episode, at the first check that sees it thrown; it
is then left to physics (it comes to rest somewhere and the bins book it as dropped).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import mujoco
import numpy as np

from sim.cell.conveyor import RAIL_GEOMS
from sim.cell.held_slots import NONE_HELD, held_mask
from sim.cell.item_pool import ItemPool
from sim.cell.items import Items, ItemsNow
from sim.flow.config import X_INFEED

THROW_SPEED_MPS = 1.5
"""An item not held moving faster than this has been struck or flung [m/s] (the belt's top
speed is 0.28 m/s; a struck can left the belt at 2.3 m/s)."""
UPSTREAM_MARGIN_M = 0.05
"""How far upstream of the infeed's drop line an item may be before it counts as thrown [m]
(items are handed over at the belt's speed and stay within 2 mm of where they drop)."""


@dataclass(frozen=True)
class Throw:
    """One item thrown off the belt.

    Attributes:
        item_id: Flow id.
        time: Sim time of the check that saw it [s].
        reason: "sideways", "upstream" or "fast".
        position: Its centre then [m].
        velocity: Its linear velocity then [m/s].
    """

    item_id: int
    time: float
    reason: str
    position: tuple[float, float, float]
    velocity: tuple[float, float, float]

    @property
    def speed(self) -> float:
        """Speed when seen [m/s]."""
        return float(np.linalg.norm(self.velocity))


def rail_outer_y(model: mujoco.MjModel) -> float:
    """|y| of the side rails' outer faces [m] (the belt's top area ends there)."""
    return max(
        abs(float(model.geom(name).pos[1])) + float(model.geom(name).size[1]) for name in RAIL_GEOMS
    )


class ThrowWatch:
    """Looks for items thrown off the belt of `model` (see the module docstring), faster
    than `speed_limit` [m/s]."""

    def __init__(self, model: mujoco.MjModel, pool: ItemPool, speed_limit: float = THROW_SPEED_MPS):
        self.pool = pool
        self.speed_limit = float(speed_limit)
        belt = pool.belt.geometry
        self.y_centre = belt.y_centre
        self.y_limit = rail_outer_y(model) - belt.y_centre
        self.x_upstream = X_INFEED - UPSTREAM_MARGIN_M
        self.released: set[int] = set()
        self._released_ids = np.zeros(64, dtype=bool)  # `released` by flow id
        self.thrown: dict[int, Throw] = {}
        self.peak_speed = 0.0
        """Fastest item seen not held and not released over a bin [m/s] (margin to the limit)."""

    def note_released(self, item_id: int) -> None:
        """The cup let go of `item_id` at the drop point: it falls into a bin, not judged."""
        item_id = int(item_id)
        self.released.add(item_id)
        if item_id >= len(self._released_ids):
            grown = np.zeros(max(2 * len(self._released_ids), item_id + 1), dtype=bool)
            grown[: len(self._released_ids)] = self._released_ids
            self._released_ids = grown
        self._released_ids[item_id] = True

    def _released_mask(self, ids: np.ndarray) -> np.ndarray:
        """(n,) whether each flow id of `ids` (n,) was let go of over a bin."""
        if len(ids) and ids.max() >= len(self._released_ids):
            grown = np.zeros(2 * int(ids.max()) + 1, dtype=bool)
            grown[: len(self._released_ids)] = self._released_ids
            self._released_ids = grown
        return self._released_ids[ids]

    def update(
        self, items: Items, held: np.ndarray = NONE_HELD, now: ItemsNow | None = None
    ) -> list[Throw]:
        """The items newly thrown off since the last call (call every few ms); the `held`
        slots (`sim.cell.held_slots`) are never judged; `now` (`Items.now`) is read here when
        None."""
        now = items.now() if now is None else now
        judged = ~self._released_mask(self.pool.item_ids[now.slots])
        if len(held):
            judged &= ~held_mask(now.slots, held)
        if not judged.any():
            return []
        pos, speed = now.positions, now.speeds
        self.peak_speed = max(self.peak_speed, float(speed[judged].max()))
        sideways = np.abs(pos[:, 1] - self.y_centre) > self.y_limit
        upstream = pos[:, 0] < self.x_upstream
        fast = speed > self.speed_limit
        off = judged & (sideways | upstream | fast)
        if not off.any():
            return []
        ids = self.pool.item_ids[now.slots]
        vel = now.velocities[:, :3]
        new = []
        for k in np.flatnonzero(off):
            item = int(ids[k])
            if item in self.thrown:
                continue
            reason = "sideways" if sideways[k] else "upstream" if upstream[k] else "fast"
            throw = Throw(
                item,
                items.time,
                reason,
                cast(tuple[float, float, float], tuple(map(float, pos[k]))),
                cast(tuple[float, float, float], tuple(map(float, vel[k]))),
            )
            self.thrown[item] = throw
            new.append(throw)
        return new
