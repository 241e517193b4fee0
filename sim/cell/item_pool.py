"""The item lifecycle on a fixed pool of bodies: spawn at the infeed, park when done.

The pool (`models/cell/items.xml`, see `sim.model.item_pool_xml`) holds `item_<n>` free bodies, each
with one geom per shape-and-pose family and a visual-only label sleeve. Spawning turns a parked
slot into one flow item: its family's geom takes the item's (scaled) size, friction and bounding
volumes (`geom_rbound`, `geom_aabb`, which MuJoCo's broad and mid phases use), collides and is
drawn in the item's colour, the label is drawn when the item has one, the body gets the item's
mass and inertia (all as MuJoCo's compiler derives them for that geom alone: a flow's items are
compiled together, `PROPS_BATCH` free bodies a model, once per flow; see `ItemPool.prepare`),
gravity, and a pose just above the belt (or above
the flat item it partly lies on) at rest. Parking hides it again, 2 m below the cell,
gravity-compensated and touching nothing, where MuJoCo puts it to sleep. Spawning and parking
write item poses and velocities here; besides them only `sim.cell.riding` does, carrying
settled items on at the belt's speed outside the integrator; otherwise only contacts move them.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from sim.cell.conveyor import Belt
from sim.errors import InvalidInput
from sim.flow.catalogue import FAMILIES, Catalogue, ItemType
from sim.flow.config import X_INFEED
from sim.model.item_pool_xml import HIDDEN_GROUP, ITEM_GROUP, LABEL, geom_name

DROP_CLEARANCE = 0.002
"""Gap between the belt and a spawned item's lowest point [m]."""
_INERTIA_FIELDS = ("body_mass", "body_inertia", "body_ipos", "body_iquat", "body_invweight0")
_GEOM_FIELDS = ("geom_size", "geom_quat", "geom_friction", "geom_rbound", "geom_aabb")
LABEL_RADIUS_GAIN = 1.04
"""A label sleeve's radius over its item's: just outside the wall, so it is drawn over it."""
LABEL_LENGTH_SHARE = 0.6
"""Share of a can's or bottle's straight part its label covers, centred."""
_CACHE_SIZE = 4096


PROPS_BATCH = 64
"""Free item bodies compiled in one model when a flow's mass properties are derived. The bodies
of a model share nothing (each hangs from the world on its own free joint), so each gets what
MuJoCo's compiler gives it alone, bit for bit (`tests/test_item_pool.py`); 64 a model costs an
eighth of a compile per item (MuJoCo's compile grows faster than linearly with the bodies:
1,024 a model costs 6x as much as 64), and thousands of one-body compiles grew the heap
(glibc's) by up to 500 MB an 8-hour flow, kept after they were freed."""


def _batch_props(item_types: list[ItemType]) -> list[dict[str, np.ndarray]]:
    """Mass properties and geom fields of each item alone, as MuJoCo's compiler derives them:
    one model of `len(item_types)` free bodies, body i + 1 holding geom i and dofs 6i..6i+5."""
    spec = mujoco.MjSpec()
    for item_type in item_types:
        body = spec.worldbody.add_body()
        body.add_freejoint()
        body.add_geom(
            type=getattr(mujoco.mjtGeom, f"mjGEOM_{item_type.shape.upper()}"),
            size=list(item_type.size) + [0.0] * (3 - len(item_type.size)),
            quat=list(item_type.geom_quat),
            mass=item_type.mass,
            friction=list(item_type.friction),
        )
    model = spec.compile()
    out = []
    for i in range(len(item_types)):
        props = {name: getattr(model, name)[i + 1].copy() for name in _INERTIA_FIELDS}
        props |= {name: getattr(model, name)[i].copy() for name in _GEOM_FIELDS}
        props["dof_invweight0"] = model.dof_invweight0[6 * i : 6 * i + 6].copy()
        props["dof_M0"] = model.dof_M0[6 * i : 6 * i + 6].copy()
        out.append(props)
    return out


def label_size(item_type: ItemType) -> tuple[float, float]:
    """(radius, half-length) [m] of the label sleeve of a round item."""
    radius, half = item_type.size
    return LABEL_RADIUS_GAIN * radius, LABEL_LENGTH_SHARE * half


POOL_MARGIN = 16
"""Bodies a pool sized for one flow has beyond the most items the flow has on the belt at once
(none picked, `sim.flow.generator.max_items_on_belt`): items falling into a bin, or held up on
the belt, stay in play a little longer than the flow's count assumes."""


def pool_size_for(most: int, capacity: int) -> int:
    """Bodies of a pool sized for a flow with at most `most` items on the belt at once: that
    and `POOL_MARGIN`, in steps of 8 (so flows of a sweep share a few compiled cells), at most
    `capacity`. Parked bodies sleep but MuJoCo still pays for each every step (kinematics,
    broad phase, integration: about 0.13 us a body); the bodies a flow uses, their order and so
    every result are the same in any pool large enough (`tests/test_item_pool.py`)."""
    return min(int(capacity), 8 * math.ceil((int(most) + POOL_MARGIN) / 8))


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
        body_ids: list[int] = []
        geom_ids: list[list[int]] = []
        grip_ids: list[int] = []
        while (
            b := mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"item_{len(body_ids)}")
        ) >= 0:
            slot = len(body_ids)
            ids = [
                mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, geom_name(slot, family))
                for family in (*FAMILIES, LABEL)
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
        self.geom_ids = np.array(geom_ids)[:, : len(FAMILIES)]
        """(slots, families) geom ids, families in `FAMILIES` order."""
        self.label_ids = np.array(geom_ids)[:, len(FAMILIES)]
        self.grip_ids = np.array(grip_ids)
        """The weld `item_<n>_grip` of each slot (the single cell's cup), -1 where none."""
        self.slot_of_body = np.full(model.nbody, -1)
        """The pool slot of each body of the model, -1 for a body that is no item."""
        self.slot_of_body[self.body_ids] = np.arange(len(body_ids))
        self.tree_ids = model.body_treeid[self.body_ids]
        self.qpos_adr = model.jnt_qposadr[model.body_jntadr[self.body_ids]]
        self.dof_adr = model.jnt_dofadr[model.body_jntadr[self.body_ids]]
        self.park_qpos = np.array([model.qpos0[a : a + 7] for a in self.qpos_adr])
        self._props: dict[tuple, dict[str, np.ndarray]] = {}
        """Mass properties of types asked one at a time (at most `_CACHE_SIZE`)."""
        self._flow_props: dict[tuple, dict[str, np.ndarray]] = {}
        """Mass properties of the prepared flow's items (`prepare`), all of them."""
        self.item_ids = np.full(len(body_ids), -1)
        self.type_index = np.full(len(body_ids), -1)
        """Catalogue index of the type (base or variant) each slot plays, -1 when parked."""
        self.active_geom = np.full(len(body_ids), -1)
        """The colliding geom of each slot, -1 when parked."""
        self._types: list[ItemType | None] = [None] * len(body_ids)

    def grip_ids_of(self, prefix: str) -> np.ndarray:
        """The welds `<prefix>item_<n>_grip` of each slot: robot `prefix`'s cup in a sorting line
        (`sim.model.line_model`), -1 where the model has none."""
        name2id, kind = mujoco.mj_name2id, mujoco.mjtObj.mjOBJ_EQUALITY
        names = (f"{prefix}item_{n}_grip" for n in range(self.size))
        return np.array([name2id(self.model, kind, name) for name in names])

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
        """The item type an active slot plays, scaled to the item's own size and mass."""
        item_type = self._types[slot]
        if item_type is None:
            raise InvalidInput("slot", "an active slot", slot)
        return item_type

    def geom_id(self, slot: int) -> int:
        """The colliding geom of an active slot."""
        return int(self.active_geom[slot])

    def _key(self, type_index: int, scale) -> tuple[tuple, ItemType]:
        """The cache key of a catalogue type at `scale`, and the scaled type."""
        item_type = self.catalogue.types[int(type_index)].scaled(scale)
        return (int(type_index), item_type.size, item_type.mass), item_type

    def prepare(self, type_indices, scales) -> None:
        """Derive the mass properties of every item of a flow (catalogue indices and scales,
        one per item), `PROPS_BATCH` a compiled model, and hold them for the flow: an episode
        compiles nothing after it is built, however long it runs. Replaces the last flow's."""
        wanted: dict[tuple, ItemType] = {}
        for type_index, scale in zip(type_indices, scales, strict=True):
            key, item_type = self._key(type_index, scale)
            wanted.setdefault(key, item_type)
        held = self._flow_props
        props = {key: held[key] for key in wanted if key in held}
        missing = [key for key in wanted if key not in props]
        for start in range(0, len(missing), PROPS_BATCH):
            keys = missing[start : start + PROPS_BATCH]
            props.update(zip(keys, _batch_props([wanted[k] for k in keys]), strict=True))
        self._flow_props = props

    def props(self, type_index: int, scale=(1.0, 1.0, 1.0)) -> dict[str, np.ndarray]:
        """Mass properties and geom fields of a catalogue type at `scale` (the prepared flow's,
        or derived now and cached)."""
        key, item_type = self._key(type_index, scale)
        props = self._flow_props.get(key) or self._props.get(key)
        if props is None:
            if len(self._props) >= _CACHE_SIZE:
                self._props.clear()
            props = self._props[key] = _batch_props([item_type])[0]
        return props

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
        scale=(1.0, 1.0, 1.0),
        label_rgba=None,
        z_drop: float = 0.0,
    ) -> int:
        """Drops flow item `item_id` onto the belt at rest, just above the surface.

        Args:
            data: Simulation state.
            item_id: Flow item id (unique among active items).
            type_index: Index into the catalogue's types.
            x, y: Belt-plane position of the item's centre [m].
            yaw: Heading of the item's x axis [rad].
            rgba: Colour (the flow's, `Flow.rgba`).
            vx: Initial velocity along the belt [m/s]: 0 drops it at rest (it then slips and,
                if round, rolls until friction brings it to the belt's speed); the belt's speed
                hands it over from a feeder at belt speed (see `feed`).
            scale: Size factors (length, width, height) of the type's nominal size.
            label_rgba: Colour of its printed label (round items); None or alpha 0: none.
            z_drop: Height above the belt of what it lands on (a flat item it partly lies
                over) [m].

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
        item_type = self.catalogue.types[type_index].scaled(scale)
        props = self.props(type_index, scale)
        geom = self.geom_ids[slot, FAMILIES.index(item_type.family)]
        m.geom_contype[geom] = m.geom_conaffinity[geom] = 1
        m.geom_group[geom] = ITEM_GROUP
        m.geom_rgba[geom] = rgba
        for name in _GEOM_FIELDS:
            getattr(m, name)[geom] = props[name]
        if label_rgba is not None and label_rgba[3] > 0 and item_type.shape != "box":
            label = self.label_ids[slot]
            radius, half = label_size(item_type)
            m.geom_size[label] = (radius, half, 0.0)
            m.geom_quat[label] = item_type.geom_quat
            m.geom_rgba[label] = label_rgba
            m.geom_group[label] = ITEM_GROUP
            m.geom_rbound[label] = math.hypot(radius, half)
            m.geom_aabb[label] = (0.0, 0.0, 0.0, radius, radius, half)
        m.body_contype[body] = m.body_conaffinity[body] = 1
        for name in _INERTIA_FIELDS:
            getattr(m, name)[body] = props[name]
        m.body_subtreemass[body] = props["body_mass"]
        dofs = slice(self.dof_adr[slot], self.dof_adr[slot] + 6)
        m.dof_invweight0[dofs] = props["dof_invweight0"]
        m.dof_M0[dofs] = props["dof_M0"]
        m.body_gravcomp[body] = 0.0
        z = self.belt.geometry.top_z + float(z_drop) + item_type.rest_height + DROP_CLEARANCE
        quat = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        self._write_pose(data, slot, (x, y, z), quat, vx)
        self.item_ids[slot], self.type_index[slot] = item_id, type_index
        self.active_geom[slot], self._types[slot] = geom, item_type
        return slot

    def park(self, data: mujoco.MjData, slot: int) -> int:
        """Takes a slot off stage; returns the flow item id it played."""
        item_id = int(self.item_ids[slot])
        if item_id < 0:
            raise InvalidInput("slot", "an active slot", slot)
        m, body = self.model, self.body_ids[slot]
        geoms = self.geom_ids[slot]
        m.geom_contype[geoms] = m.geom_conaffinity[geoms] = 0
        geoms = np.append(geoms, self.label_ids[slot])
        m.geom_group[geoms] = HIDDEN_GROUP
        m.geom_rgba[geoms, 3] = 0.0
        m.body_contype[body] = m.body_conaffinity[body] = 0
        m.body_gravcomp[body] = 1.0
        if self.grip_ids[slot] >= 0:
            data.eq_active[self.grip_ids[slot]] = 0
        park = self.park_qpos[slot]
        self._write_pose(data, slot, park[:3], park[3:])
        self.item_ids[slot], self.type_index[slot] = -1, -1
        self.active_geom[slot], self._types[slot] = -1, None
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
        them as if they moved with the belt from the drop on, apart by the world's gap. Dropped
        at rest instead, a lying can lags 2.6 cm behind while it spins up and stops rolling,
        enough to hit the next item of its stripe.

        Args:
            data: Simulation state (its time decides which items are due).
            flow: A `sim.flow.generator.Flow` (item `i` drops at `flow.t_spawn[i]` at x = X_INFEED).
            start: First flow index not spawned yet.
        """
        i, t = start, float(data.time)
        while i < len(flow) and flow.t_spawn[i] <= t:
            # Dropped a fraction of a step late: place it where the belt has carried it since.
            self.drop(data, flow, i, X_INFEED + self.belt.speed * (t - float(flow.t_spawn[i])))
            i += 1
        return i

    def drop(self, data: mujoco.MjData, flow, i: int, x: float, raise_m: float = 0.0) -> int:
        """Spawns flow item `i` at `x` along the belt [m], handed over at the belt's speed,
        `raise_m` [m] higher than the flow drops it; returns its slot."""
        k, y, yaw = int(flow.variant[i]), float(flow.y[i]), float(flow.yaw[i])
        return self.spawn(
            data, i, k, x, y, yaw, flow.rgba[i], vx=self.belt.speed, scale=flow.scale[i],
            label_rgba=flow.label_rgba[i], z_drop=float(flow.z_drop[i]) + raise_m,
        )  # fmt: skip

    def park_missed(self, data: mujoco.MjData) -> list[int]:
        """Parks the items whose centre has passed the belt's discharge end; returns their ids.

        These are the items the robot did not pick (the thesis's discarded items).
        """
        active = self.active_slots()
        past = active[data.xpos[self.body_ids[active], 0] > self.belt.geometry.x_discharge]
        return [self.park(data, int(slot)) for slot in past]
