"""The vacuum cup as the episode runner drives it: touching, seal, hold, release.

A thin adapter: when `sim.suction` (the cup's physical model: seal on contact after the vacuum
build-up, force budget, release time) is available it is used; until then a weld between the
cup and the touched item (the pool's `item_<n>_grip` equality, activated with the current
relative pose) stands in for it.
"""

from __future__ import annotations

import mujoco
import numpy as np

from sim.cell import Cell

CUP_BODY = "cup_link"


class Gripper:
    """Seal and release on the pool's items by their `item_<n>_grip` welds."""

    def __init__(self, cell: Cell):
        self.cell = cell
        model = cell.model
        self.cup = model.body(CUP_BODY).id
        self._slot_of_body = {int(b): s for s, b in enumerate(cell.pool.body_ids)}
        self.held: int | None = None

    def touching_slot(self) -> int:
        """Pool slot of an item in contact with the cup now, -1 for none."""
        model, data = self.cell.model, self.cell.data
        for i in range(data.ncon):
            c = data.contact[i]
            b1, b2 = model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2]
            if b1 == self.cup and b2 in self._slot_of_body:
                return self._slot_of_body[int(b2)]
            if b2 == self.cup and b1 in self._slot_of_body:
                return self._slot_of_body[int(b1)]
        return -1

    def seal(self, slot: int) -> int:
        """Weld the item of `slot` to the cup in its current relative pose; returns the slot."""
        model, data = self.cell.model, self.cell.data
        eq = int(self.cell.pool.grip_ids[slot])
        body = int(self.cell.pool.body_ids[slot])
        # eq_data of a weld: anchor (3), relative pose of body2 in body1 (pos 3, quat 4), scale.
        cup_pos, cup_mat = data.xpos[self.cup], data.xmat[self.cup].reshape(3, 3)
        rel_pos = cup_mat.T @ (data.xpos[body] - cup_pos)
        cup_quat = np.empty(4)
        mujoco.mju_mat2Quat(cup_quat, data.xmat[self.cup])
        inv = np.empty(4)
        mujoco.mju_negQuat(inv, cup_quat)
        rel_quat = np.empty(4)
        mujoco.mju_mulQuat(rel_quat, inv, data.xquat[body])
        first = model.eq_obj1id[eq] == self.cup
        anchor = np.zeros(3)
        if first:
            model.eq_data[eq, 3:6] = rel_pos
            model.eq_data[eq, 6:10] = rel_quat
        else:  # body1 is the item: the cup's pose in the item's frame
            item_mat = data.xmat[body].reshape(3, 3)
            model.eq_data[eq, 3:6] = item_mat.T @ (cup_pos - data.xpos[body])
            inv_rel = np.empty(4)
            mujoco.mju_negQuat(inv_rel, rel_quat)
            model.eq_data[eq, 6:10] = inv_rel
        model.eq_data[eq, 0:3] = anchor
        data.eq_active[eq] = 1
        self.held = slot
        return slot

    def holding(self, slot: int) -> bool:
        """Whether the cup still holds the item of `slot`."""
        return self.held == slot and bool(self.cell.data.eq_active[self.cell.pool.grip_ids[slot]])

    def release(self) -> None:
        """Release the held item, if any."""
        if self.held is not None:
            self.cell.data.eq_active[self.cell.pool.grip_ids[self.held]] = 0
            self.held = None
