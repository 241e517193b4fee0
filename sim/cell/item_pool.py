"""The item lifecycle on a fixed pool of bodies: spawn at the infeed, park when done.

The pool (`models/cell/items.xml`, see `sim.cell.item_pool_xml`) holds `item_<n>` free bodies, each
with one geom per catalogue type. Spawning turns a parked slot into one flow item: the type's geom
collides and is drawn in the flow's colour, the body gets the type's mass and inertia (as MuJoCo
computes them for that geom alone), gravity, and a pose just above the belt at rest. Parking
hides it again, 2 m below the cell, gravity-compensated and touching nothing, where MuJoCo puts
it to sleep. Spawning and parking are the only places item poses or velocities are written;
while an item rides, only contacts move it.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from sim.cell.conveyor import Belt
from sim.cell.item_pool_xml import HIDDEN_GROUP, ITEM_GROUP, geom_name
from sim.errors import InvalidInput
from sim.flow.catalogue import Catalogue, ItemType
from sim.flow.config import X_INFEED

DROP_CLEARANCE = 0.002
"""Gap between the belt and a spawned item's lowest point [m]."""
_INERTIA_FIELDS = ("body_mass", "body_inertia", "body_ipos", "body_iquat", "body_invweight0")


def _type_inertia(item_type: ItemType) -> dict[str, np.ndarray]:
    """Mass properties of one item alone, as MuJoCo's compiler derives them from its geom."""
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body()
    body.add_freejoint()
    body.add_geom(
        type=getattr(mujoco.mjtGeom, f"mjGEOM_{item_type.shape.upper()}"),
        size=list(item_type.size) + [0.0] * (3 - len(item_type.size)),
        quat=list(item_type.geom_quat),
        mass=item_type.mass,
    )
    model = spec.compile()
    props = {name: getattr(model, name)[1].copy() for name in _INERTIA_FIELDS}
    props["dof_invweight0"] = model.dof_invweight0[:6].copy()
    props["dof_M0"] = model.dof_M0[:6].copy()
    return props


class ItemPool:
    """Which pool slot plays which flow item, and the writes that spawn and park them.

    Args:
        model: Compiled cell (or test scene) including the item pool; its geom fields are
            switched at run time, so give each simulation its own model.
        catalogue: The catalogue the pool was generated from.
        belt: The belt the items are dropped on.

    Raises:
        InvalidInput: the model has no item pool or it does not match the catalogue.
    """

    def __init__(self, model: mujoco.MjModel, catalogue: Catalogue, belt: Belt):
        self.model, self.catalogue, self.belt = model, catalogue, belt
        body_ids, geom_ids, grip_ids = [], [], []
        while (
            b := mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"item_{len(body_ids)}")
        ) >= 0:
            slot = len(body_ids)
            ids = [
                mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, geom_name(slot, t))
                for t in catalogue.types
            ]
            if min(ids) < 0:
                raise InvalidInput("items.xml", "a pool generated from this catalogue", slot)
            body_ids.append(b)
            geom_ids.append(ids)
            grip_ids.append(
                mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, f"item_{slot}_grip")
            )
        if not body_ids:
            raise InvalidInput("model", "a scene including models/cell/items.xml", None)
        self.body_ids = np.array(body_ids)
        self.geom_ids = np.array(geom_ids)
        self.grip_ids = np.array(grip_ids)
        self.tree_ids = model.body_treeid[self.body_ids]
        self.qpos_adr = model.jnt_qposadr[model.body_jntadr[self.body_ids]]
        self.dof_adr = model.jnt_dofadr[model.body_jntadr[self.body_ids]]
        self.park_qpos = np.array([model.qpos0[a : a + 7] for a in self.qpos_adr])
        self._inertia = [_type_inertia(t) for t in catalogue.types]
        self.item_ids = np.full(len(body_ids), -1)
        self.type_index = np.full(len(body_ids), -1)

    @property
    def size(self) -> int:
        """Number of slots."""
        return len(self.body_ids)

    def active_slots(self) -> np.ndarray:
        """Slots playing an item."""
        return np.flatnonzero(self.item_ids >= 0)

    def slot_of(self, item_id: int) -> int | None:
        """Slot playing flow item `item_id`, or None."""
        hits = np.flatnonzero(self.item_ids == item_id)
        return int(hits[0]) if len(hits) else None

    def item_type(self, slot: int) -> ItemType:
        """Catalogue type a slot currently plays."""
        return self.catalogue.types[self.type_index[slot]]

    def geom_id(self, slot: int) -> int:
        """The colliding geom of an active slot."""
        return int(self.geom_ids[slot, self.type_index[slot]])

    def position(self, data: mujoco.MjData, slot: int) -> np.ndarray:
        """World position of a slot's body origin (the item's centre) [m]."""
        return data.xpos[self.body_ids[slot]].copy()

    def spawn(
        self,
        data: mujoco.MjData,
        item_id: int,
        type_index: int,
        x: float,
        y: float,
        yaw: float,
        rgba,
        vx: float = 0.0,
    ) -> int:
        """Drops flow item `item_id` onto the belt at rest, just above the surface.

        Args:
            data: Simulation state.
            item_id: Flow item id (unique among active items).
            type_index: Index into the catalogue's types.
            x, y: Belt-plane position of the item's centre [m].
            yaw: Heading of the item's x axis [rad].
            rgba: Colour (from the catalogue's colour table, chosen by the flow).
            vx: Initial velocity along the belt [m/s]: 0 drops it at rest (it then slips and,
                if round, rolls until friction brings it to the belt's speed); the belt's speed
                hands it over from a feeder at belt speed (see `feed`).

        Returns:
            The slot used.

        Raises:
            InvalidInput: no free slot, an id already on the belt, or an unknown type.
        """
        if not 0 <= type_index < len(self.catalogue.types):
            raise InvalidInput("type_index", f"0..{len(self.catalogue.types) - 1}", type_index)
        if self.slot_of(item_id) is not None:
            raise InvalidInput("item_id", "an id not already on the belt", item_id)
        free = np.flatnonzero(self.item_ids < 0)
        if not len(free):
            raise InvalidInput(
                "items on the belt", f"at most {self.size} (the pool)", self.size + 1
            )
        slot = int(free[0])
        m, body = self.model, self.body_ids[slot]
        item_type = self.catalogue.types[type_index]
        geom = self.geom_ids[slot, type_index]
        m.geom_contype[geom] = m.geom_conaffinity[geom] = 1
        m.geom_group[geom] = ITEM_GROUP
        m.geom_rgba[geom] = rgba
        m.body_contype[body] = m.body_conaffinity[body] = 1
        props = self._inertia[type_index]
        for name in _INERTIA_FIELDS:
            getattr(m, name)[body] = props[name]
        m.body_subtreemass[body] = props["body_mass"]
        dofs = slice(self.dof_adr[slot], self.dof_adr[slot] + 6)
        m.dof_invweight0[dofs] = props["dof_invweight0"]
        m.dof_M0[dofs] = props["dof_M0"]
        m.body_gravcomp[body] = 0.0
        z = self.belt.geometry.top_z + item_type.rest_height + DROP_CLEARANCE
        quat = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        self._write_pose(data, slot, (x, y, z), quat, vx)
        self.item_ids[slot], self.type_index[slot] = item_id, type_index
        return slot

    def park(self, data: mujoco.MjData, slot: int) -> int:
        """Takes a slot off stage; returns the flow item id it played."""
        item_id = int(self.item_ids[slot])
        if item_id < 0:
            raise InvalidInput("slot", "an active slot", slot)
        m, body = self.model, self.body_ids[slot]
        geoms = self.geom_ids[slot]
        m.geom_contype[geoms] = m.geom_conaffinity[geoms] = 0
        m.geom_group[geoms] = HIDDEN_GROUP
        m.geom_rgba[geoms, 3] = 0.0
        m.body_contype[body] = m.body_conaffinity[body] = 0
        m.body_gravcomp[body] = 1.0
        if self.grip_ids[slot] >= 0:
            data.eq_active[self.grip_ids[slot]] = 0
        park = self.park_qpos[slot]
        self._write_pose(data, slot, park[:3], park[3:])
        self.item_ids[slot], self.type_index[slot] = -1, -1
        return item_id

    def _write_pose(self, data: mujoco.MjData, slot: int, pos, quat, vx: float = 0.0) -> None:
        adr, dof = self.qpos_adr[slot], self.dof_adr[slot]
        data.qpos[adr : adr + 3] = pos
        data.qpos[adr + 3 : adr + 7] = quat
        data.qvel[dof : dof + 6] = 0.0
        data.qvel[dof] = vx
        data.qacc_warmstart[dof : dof + 6] = 0.0
        # A sleeping tree whose awake flag is set is woken by the next step (mj_wake).
        data.tree_awake[self.tree_ids[slot]] = 1

    def feed(self, data: mujoco.MjData, flow, start: int) -> int:
        """Spawns the flow's items due by `data.time`, from index `start`; returns the next index.

        Items are handed over at the belt's speed, as from an infeed conveyor: the flow places
        them as if they moved with the belt from the drop on, 5 mm apart. Dropped at rest
        instead, a lying can lags 2.6 cm behind while it spins up and stops rolling, enough to
        hit the next item of its stripe.

        Args:
            data: Simulation state (its time decides which items are due).
            flow: A `sim.flow.generator.Flow` (item `i` drops at `flow.t_spawn[i]` at x = X_INFEED).
            start: First flow index not spawned yet.
        """
        i, t = start, float(data.time)
        while i < len(flow) and flow.t_spawn[i] <= t:
            # Dropped a fraction of a step late: place it where the belt has carried it since.
            x = X_INFEED + self.belt.speed * (t - float(flow.t_spawn[i]))
            rgba = self.catalogue.rgba[int(flow.colour[i])]
            k, y, yaw = int(flow.type_index[i]), float(flow.y[i]), float(flow.yaw[i])
            self.spawn(data, i, k, x, y, yaw, rgba, vx=self.belt.speed)
            i += 1
        return i

    def park_missed(self, data: mujoco.MjData) -> list[int]:
        """Parks the items whose centre has passed the belt's discharge end; returns their ids.

        These are the items the robot did not pick (the thesis's discarded items).
        """
        active = self.active_slots()
        past = active[data.xpos[self.body_ids[active], 0] > self.belt.geometry.x_discharge]
        return [self.park(data, int(slot)) for slot in past]
