"""The vacuum cup on the robot's `cup_link`: seal on contact, hold within a force budget, release.

Model (numbers and reasons in docs/suction.md):
- Seal. With the vacuum on, the cup seals on an item only while its lip (the cup's collision
  geom) touches the item and the lip lies on the item: the cup's axis meets the item's footprint
  at least `edge_margin` x the cup radius inside its outline (a bellows lip may hang over a
  rounded edge by half its radius, not more). The vacuum then builds up for `seal_time` (35 ms,
  ABB's Cycle 1 figure) of contact; then the item is held. A light item chatters under the
  pressing lip (MuJoCo's contact comes and goes for a step at a time): a break in the contact
  of at most `SEAL_GAP_S` does not restart the build-up (the cup's air cannot rush back in a
  millisecond through a gap of a fraction of a millimetre); a longer one, or the lip on another
  item, does.
- Hold. A held item is welded to `cup_link` (the pool's `item_<n>_grip` weld, activated with the
  current relative pose written into `eq_data`, so the seal forms where the cup touched and
  nothing jumps). A weld carries the loads exactly as a sealed cup does and lets us read the
  load it carries; MuJoCo's `adhesion` actuator, the alternative, pulls along contact normals
  through soft contacts, so the cup would sink into the item and its holding force would depend
  on contact stiffness rather than on cup area x vacuum. Every step the cup's force on the item
  is obtained from the item's own motion, F = m (a - g) - (forces of its other contacts), and
  split along the cup axis: the pull-off part F_n (away from the lip) and the shear part F_t.
  The seal fails, and the item drops, when F_n + F_t / mu_lip > area x vacuum (the vacuum
  presses the lip on the item with area x vacuum; pull-off uses that up, shear needs friction
  mu_lip on what is left).
- Release. Vacuum off: the item stays held for `release_time` (35 ms of air), then drops.

A robot of a sorting line (`sim.model.line_model`) has its own cup: `SuctionCup(..., prefix="r1_")`
acts through `r1_cup_link`, `r1_cup_site` and the pool's welds `r1_item_<n>_grip`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from planner.motion.limits import VACUUM_RELEASE_S, VACUUM_SEAL_S
from sim.cell.item_pool import ItemPool
from sim.errors import InvalidInput

CUP_BODY = "cup_link"
CUP_SITE = "cup_site"
SEAL_GAP_S = 0.002
"""Longest break in the lip's contact that does not restart the seal's build-up [s]."""
TOPPLED_AXIS_Z = math.sqrt(0.5)
"""A standing item whose axis is less upright than this (its vertical component; 45 deg) has
toppled: the cup meets its side, as a lying item's."""


@dataclass(frozen=True)
class SuctionConfig:
    """Vacuum parameters (the cup's diameter is the model's: the cup's collision geom).

    Attributes:
        vacuum: Vacuum level below atmosphere at the sealed cup [Pa] (80 kPa: a multi-stage
            ejector on the thesis's 10 bar supply, non-porous item).
        lip_friction: Friction coefficient of the rubber lip on the item (shear capacity).
        seal_time: Vacuum build-up after the lip touches the item [s].
        release_time: Time from vacuum off until the item drops [s].
        edge_margin: How far inside the item's outline the cup axis must meet it, as a
            fraction of the cup radius.
    """

    vacuum: float = 80e3
    lip_friction: float = 1.0
    seal_time: float = VACUUM_SEAL_S
    release_time: float = VACUUM_RELEASE_S
    edge_margin: float = 0.5

    def __post_init__(self):
        checks = {
            "vacuum": (0.0 < self.vacuum <= 101.325e3, "0 < vacuum <= 101325 Pa"),
            "lip_friction": (0.0 < self.lip_friction <= 2.0, "0 < lip_friction <= 2"),
            "seal_time": (0.0 <= self.seal_time <= 1.0, "0 to 1 s"),
            "release_time": (0.0 <= self.release_time <= 1.0, "0 to 1 s"),
            "edge_margin": (0.0 <= self.edge_margin <= 1.0, "0 to 1"),
        }
        for name, (ok, allowed) in checks.items():
            if not (math.isfinite(getattr(self, name)) and ok):
                raise InvalidInput(f"suction.{name}", allowed, getattr(self, name))


@dataclass(frozen=True)
class SuctionEvent:
    """Something the cup did: "sealed", "lost" (force budget exceeded) or "released"."""

    kind: str
    time: float
    item_id: int
    slot: int
    load: float = 0.0


class SuctionCup:
    """The vacuum cup of the robot in `model`, acting on the items of `pool`.

    Call `update(data)` after every physics step (or control period) and switch the vacuum
    with `vacuum_on` / `vacuum_off`. `prefix` names the robot whose cup this is ("" for the
    robot's own names); `measure_load` has every step's load of a held item measured
    (`peak_load`), which the cup otherwise works out only when it could exceed the budget.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        pool: ItemPool,
        config: SuctionConfig | None = None,
        *,
        prefix: str = "",
        measure_load: bool = False,
    ):
        self.model, self.pool = model, pool
        self.config = config or SuctionConfig()
        self.measure_load = bool(measure_load)
        """Compute the held item's load every step (`last_load`, `peak_load`); else only when
        its force could reach the budget (the drops are the same)."""
        self.last_load = self.peak_load = 0.0
        self.prefix = prefix
        self.body_id = model.body(prefix + CUP_BODY).id
        self.site_id = model.site(prefix + CUP_SITE).id
        self.grip_ids = pool.grip_ids if prefix == "" else pool.grip_ids_of(prefix)
        """This cup's weld of each pool slot (-1 where the model has none)."""
        first = model.body_geomadr[self.body_id]
        geoms = np.arange(first, first + model.body_geomnum[self.body_id])
        geoms = geoms[(model.geom_contype[geoms] | model.geom_conaffinity[geoms]) != 0]
        if len(geoms) != 1 or model.geom_type[geoms[0]] != mujoco.mjtGeom.mjGEOM_CYLINDER:
            raise InvalidInput("cup", "one colliding cylinder geom on cup_link (the lip)", geoms)
        self.geom_id = int(geoms[0])
        self.radius = float(model.geom_size[self.geom_id, 0])
        self._vacuum = False
        # (slot, time the lip touched it, last time it touched it)
        self._sealing: tuple[int, float, float] | None = None
        self._held: int | None = None
        self._release_at: float | None = None
        self.events: list[SuctionEvent] = []
        """The cup's events not yet taken (`take_events`): a shift's are not all kept."""
        self._force = np.zeros(6)
        # [m/s^2] (read once: the option never changes)
        self._gravity = tuple(model.opt.gravity.tolist())
        self._budget = self.force_budget  # [N], read every step while holding
        # A load below this cannot reach the budget however it splits into pull-off and shear
        # (F_n + F_t / mu <= |F| (1 + 1 / mu)), with a margin for the rounding [N].
        self._safe_force = self._budget / (1.0 + 1.0 / self.config.lip_friction) * (1.0 - 1e-9)
        self._nominal: SuctionConfig | None = (
            None  # the configured vacuum, while `supply` lowers it
        )
        self._parts: tuple[int, int, int, float, int] | None = None  # `_held_parts`' last
        # Views of the data's arrays read every step (`_views`).
        self._data_views: tuple | None = None

    @property
    def area(self) -> float:
        """Area of the cup's lip opening [m^2]."""
        return math.pi * self.radius**2

    @property
    def force_budget(self) -> float:
        """Holding force of the sealed cup, area x vacuum [N]."""
        return self.area * self.config.vacuum

    @property
    def held_slot(self) -> int | None:
        """Pool slot of the held item, or None."""
        return self._held

    @property
    def held_item(self) -> int | None:
        """Flow id of the held item, or None."""
        return None if self._held is None else int(self.pool.item_ids[self._held])

    @property
    def vacuum(self) -> bool:
        """Whether the vacuum valve is open."""
        return self._vacuum

    @property
    def active(self) -> bool:
        """Whether `update` has anything to do: the vacuum is on or an item is held (else it
        changes nothing and returns no event)."""
        return self._vacuum or self._held is not None

    def supply(self, vacuum_pa: float | None) -> None:
        """The supply's vacuum falls to `vacuum_pa` [Pa] (None: back to the configured level):
        the holding force falls with it (area x vacuum), and the seal builds up slower, its
        time the configured one times the configured vacuum over this one (the cup's volume
        drawn down by a weaker supply; at most 1 s)."""
        if self._nominal is None:
            self._nominal = self.config
        nominal = self._nominal
        config = nominal
        if vacuum_pa is not None:
            slower = nominal.seal_time * nominal.vacuum / float(vacuum_pa)
            config = replace(nominal, vacuum=float(vacuum_pa), seal_time=min(slower, 1.0))
        self.config = config
        self._budget = self.force_budget
        self._safe_force = self._budget / (1.0 + 1.0 / config.lip_friction) * (1.0 - 1e-9)

    @property
    def seal_delay(self) -> float:
        """How much longer the seal takes now than at the configured vacuum [s] (0 unless
        `supply` lowered it): what a vacuum switch makes the controller wait on the item."""
        if self._nominal is None:
            return 0.0
        return max(self.config.seal_time - self._nominal.seal_time, 0.0)

    def vacuum_on(self) -> None:
        """Opens the vacuum valve."""
        self._vacuum = True
        self._release_at = None

    def vacuum_off(self, time: float) -> None:
        """Closes the vacuum (and blows off): a held item drops after `release_time`."""
        self._vacuum = False
        self._sealing = None
        if self._held is not None and self._release_at is None:
            self._release_at = time + self.config.release_time

    def update(self, data: mujoco.MjData) -> list[SuctionEvent]:
        """Advances the cup's state to `data.time`; returns the events of this call."""
        events: list[SuctionEvent] = []
        t = float(data.time)
        if self._held is not None:
            if self._release_at is not None and t >= self._release_at - 1e-9:
                events.append(self._drop(data, "released", t))
            else:
                assert self._parts is not None  # read when the item was sealed on
                _, _, dof, mass, geom = self._parts  # the item sealed on (`_seal`)
                fx, fy, fz = self._force_on(data, dof, mass, geom)
                near = fx * fx + fy * fy + fz * fz >= self._safe_force * self._safe_force
                if near or self.measure_load:
                    load = self._load_of(data, self._held, fx, fy, fz)
                    self.last_load, self.peak_load = load, max(self.peak_load, load)
                    if load > self._budget:
                        events.append(self._drop(data, "lost", t, load))
        elif self._vacuum:
            slot, sealing = self._touched_slot(data), self._sealing
            if slot is None:  # a short break keeps the build-up
                if sealing is not None and t - sealing[2] > SEAL_GAP_S + 1e-9:
                    self._sealing = None
            elif sealing is None or sealing[0] != slot:
                self._sealing = (slot, t, t)
            elif t - sealing[1] >= self.config.seal_time - 1e-9:
                self._seal(data, slot)
                events.append(SuctionEvent("sealed", t, int(self.pool.item_ids[slot]), slot))
            else:
                self._sealing = (slot, sealing[1], t)
        self.events += events
        return events

    def take_events(self) -> list[SuctionEvent]:
        """The events since the last call, in order; the cup keeps them no longer."""
        taken, self.events = self.events, []
        return taken

    def _touched_slot(self, data: mujoco.MjData) -> int | None:
        """Active slot whose item the lip touches and lies on, or None. Where it touches
        several (a scrap lying on a board), the highest (its centre): the surface the lip is
        pressed against, the top of the pile."""
        n = data.ncon
        if n == 0:
            return None
        geoms = data.contact.geom[:n]
        touching = np.concatenate(
            [geoms[geoms[:, 0] == self.geom_id, 1], geoms[geoms[:, 1] == self.geom_id, 0]]
        )
        tried = set()  # a slot the lip touches at several points is judged once
        best, best_z = None, -math.inf
        for slot in self.pool.slot_of_body[self.model.geom_bodyid[touching]].tolist():
            if slot < 0 or slot in tried:
                continue
            tried.add(slot)
            if self.pool.item_ids[slot] >= 0 and self._lip_on_item(data, slot):
                z = float(data.xpos[self.pool.body_ids[slot], 2])
                if z > best_z:
                    best, best_z = slot, z
        return best

    def _lip_on_item(self, data: mujoco.MjData, slot: int) -> bool:
        """Whether the cup axis meets the item's footprint far enough inside its outline."""
        body = self.pool.body_ids[slot]
        rot = data.xmat[body].reshape(3, 3)
        d = data.site_xpos[self.site_id] - data.xpos[body]  # the cup's axis from the centre
        local = rot.T @ d
        item_type = self.pool.item_type(slot)
        margin = self.config.edge_margin * self.radius
        kind, a, b = item_type.footprint
        lx, ly = abs(local[0]), abs(local[1])
        toppled = item_type.pose == "standing" and abs(rot[2, 2]) < TOPPLED_AXIS_Z
        if toppled or item_type.pose == "lying":
            # A can or bottle lying on its side may roll about its axis (a lying item's body x,
            # a toppled standing can's body z): the lip's offset along the axis, and across it
            # in the belt's plane.
            axis = rot[:, 2] if toppled else rot[:, 0]
            along = float(d @ axis)
            perp = d - along * axis
            ly = math.hypot(perp[0], perp[1])
            if toppled:  # its side under the lip as a lying can's
                radius, half = item_type.size
                kind, a, b, lx = "rect", half, radius, abs(along)
        if kind == "disc":
            return bool(math.hypot(lx, ly) <= a - margin)
        if kind == "rect":
            return bool(lx <= a - margin and ly <= b - margin)
        beyond = max(lx - a, 0.0)  # stadium: straight part of half-length a, round ends of radius b
        return bool(math.hypot(beyond, ly) <= b - margin)

    def _seal(self, data: mujoco.MjData, slot: int) -> None:
        eq = self.grip_ids[slot]
        if eq < 0:
            raise InvalidInput("items.xml", "a grip weld per item slot", slot)
        b1, b2 = self.body_id, self.pool.body_ids[slot]
        r1 = data.xmat[b1].reshape(3, 3)
        relpos = r1.T @ (data.xpos[b2] - data.xpos[b1])
        q1_inv = np.empty(4)
        mujoco.mju_negQuat(q1_inv, data.xquat[b1])
        relquat = np.empty(4)
        mujoco.mju_mulQuat(relquat, q1_inv, data.xquat[b2])
        self.model.eq_data[eq, 0:3] = 0.0
        self.model.eq_data[eq, 3:6] = relpos
        self.model.eq_data[eq, 6:10] = relquat
        data.eq_active[eq] = 1
        self._held, self._sealing, self.last_load = slot, None, 0.0
        self._held_parts(slot)  # read once for the steps it is held

    def _drop(self, data: mujoco.MjData, kind: str, t: float, load: float = 0.0) -> SuctionEvent:
        slot = self._held
        assert slot is not None  # only a held item is dropped
        data.eq_active[self.grip_ids[slot]] = 0
        self._held, self._release_at = None, None
        return SuctionEvent(kind, t, int(self.pool.item_ids[slot]), slot, load)

    def _held_parts(self, slot: int) -> tuple[int, int, int, float, int]:
        """(slot, body, first dof, mass [kg], colliding geom) of the item in `slot`, read once
        per item held (the pool changes them only when it spawns another item there)."""
        parts = self._parts
        if parts is None or parts[0] != slot or parts[3] != self.model.body_mass[parts[1]]:
            body = int(self.pool.body_ids[slot])
            mass = float(self.model.body_mass[body])
            parts = (slot, body, int(self.pool.dof_adr[slot]), mass, self.pool.geom_id(slot))
            self._parts = parts
        return parts

    def _views(self, data: mujoco.MjData) -> tuple:
        """Views of `data`'s arrays read every step while holding (made once per data)."""
        views = self._data_views
        if views is None or views[0] is not data:
            views = (data, data.qacc, data.site_xmat, data.site_xpos, data.xpos)
            self._data_views = views
        return views

    def cup_force(self, data: mujoco.MjData, slot: int) -> tuple[float, float, float]:
        """Force of the cup on the item in `slot` [N, world]: m (a - g) - its other contacts.

        Runs every step while the cup holds an item: worked in Python floats (the same
        operations as on numpy's float64); the contacts are scanned as a list (a handful a
        step), and only those with anything but the lip (the item still on the belt,
        touching a neighbour) are read from MuJoCo."""
        _, _, dof, mass, geom = self._held_parts(slot)
        return self._force_on(data, dof, mass, geom)

    def _force_on(
        self, data: mujoco.MjData, dof: int, mass: float, geom: int
    ) -> tuple[float, float, float]:
        """`cup_force` on the item of first dof `dof`, mass `mass` [kg] and geom `geom`."""
        ax, ay, az = self._views(data)[1][dof : dof + 3].tolist()
        gx, gy, gz = self._gravity
        fx, fy, fz = mass * (ax - gx), mass * (ay - gy), mass * (az - gz)
        n = data.ncon
        if not n:
            return fx, fy, fz
        lip = self.geom_id
        for i, (first, second) in enumerate(data.contact.geom[:n].tolist()):
            if first == geom:
                side, other = 0, second
            elif second == geom:
                side, other = 1, first
            else:
                continue
            if other == lip:
                continue  # the lip (the usual contacts while holding): the force sought
            mujoco.mj_contactForce(self.model, data, i, self._force)
            frame = data.contact.frame[i].reshape(3, 3)
            world = frame.T @ self._force[:3]  # force on geom[1] from geom[0], world frame
            wx, wy, wz = (world if side == 1 else -world).tolist()
            fx, fy, fz = fx - wx, fy - wy, fz - wz
        return fx, fy, fz

    def load(self, data: mujoco.MjData, slot: int) -> float:
        """Equivalent pull-off load on the seal, F_n + F_t / mu_lip [N] (against the budget)."""
        return self._load_of(data, slot, *self.cup_force(data, slot))

    def _load_of(self, data: mujoco.MjData, slot: int, fx: float, fy: float, fz: float) -> float:
        """`load` of the cup's force (fx, fy, fz) [N] on the item in `slot`."""
        _, site_xmat, site_xpos, xpos = self._views(data)[1:]
        ax, ay, az = site_xmat[self.site_id, 2::3].tolist()  # the lip's axis in the world
        lx, ly, lz = site_xpos[self.site_id].tolist()
        cx, cy, cz = xpos[self._held_parts(slot)[1]].tolist()
        if ax * (cx - lx) + ay * (cy - ly) + az * (cz - lz) < 0:
            ax, ay, az = -ax, -ay, -az  # unit vector from the lip into the item
        along = fx * ax + fy * ay + fz * az
        pull = max(0.0, -along)  # the cup pulling the item towards itself
        shear = math.sqrt(max(fx * fx + fy * fy + fz * fz - along * along, 0.0))
        return float(pull + shear / self.config.lip_friction)
