"""The infeed holds an item back while it would drop into an item already on the belt.

The flow places each item as if it rode with the belt from its drop on, clear of the items
before it (`sim.flow.generator`), and hands it over at the belt's speed. An item that has not
kept its place (a lying can or bottle that rolled back off the flat item it was dropped on, one
knocked upstream) can lie where the next item is dropped: spawned inside it, MuJoCo pushes the
two apart with the force of a deep penetration and throws one of them off the belt (most of
the items a four-robot line at 3.3 items/s lost, `docs/line.md`). A real feeder cannot drop an
item into another. `dropped_into` says whether an item just dropped penetrates another item
deeper than `DEEP_M` (MuJoCo's signed distance of the two geoms, `mj_geomDistance`): the
episode then takes it back and drops it at the infeed's end a step later, until it drops clear
(after `MAX_HOLD_S` it is dropped onto what is still there); the items due after it drop as
planned meanwhile. Shallower overlaps (a few millimetres, frequent at a line's densities) are
left to the contact solver, which separates them gently.
"""

from __future__ import annotations

import mujoco
import numpy as np

from sim.cell.item_pool import ItemPool

DEEP_M = 0.01
"""An item dropped into another deeper than this is held back [m]."""
MAX_HOLD_S = 2.0
"""Longest time one item is held back [s] (the belt carries the longest item, 0.35 m, past in
1.9 s at x1); then what still lies there is stuck (a jam at the infeed) and the item is dropped
onto it, raised in steps of `RAISE_STEP_M` until it clears it."""
RAISE_STEP_M = 0.01
"""Step by which an item that waited `MAX_HOLD_S` is raised above the item in its way [m]."""
MAX_RAISE_M = 0.2
"""Highest it is raised [m] (above the tallest item standing)."""


def dropped_into(model: mujoco.MjModel, data: mujoco.MjData, pool: ItemPool, slot: int) -> bool:
    """Whether the item just dropped in `slot` (posed: `mj_kinematics` run) penetrates another
    active item deeper than `DEEP_M`."""
    geom = pool.geom_id(slot)
    others = pool.active_geom[pool.active_slots()]
    others = others[others != geom]
    # Only the items whose bounding spheres overlap its own can lie inside it.
    gap = np.linalg.norm(data.geom_xpos[others] - data.geom_xpos[geom], axis=1)
    near = others[gap < model.geom_rbound[geom] + model.geom_rbound[others]]
    return any(
        mujoco.mj_geomDistance(model, data, geom, int(g), DEEP_M, None) < -DEEP_M
        for g in near.tolist()
    )
