"""The robot's side of an episode: plan the chosen pick, play it in physics, seal, release.

The chosen item is met where it will be (`planner.motion.intercept.intercept_item`: ruckig chain
arriving on the item at the belt's velocity), the chain is played by
`sim.cell.executor.TrajectoryExecutor` (IK motor set-points at every physics step), and the vacuum
cup (`sim.cell.suction.SuctionCup`) seals if its lip rests on an item for the seal time, holds it
within its force budget, and lets it go over the bin.

Nothing but the item picked is to be touched: the empty cup comes down over the tallest
neighbour near its path (the plan is checked against the items around, as they ride on, and
the corner above the item raised where it passes one too low), the lift keeps the belt's
velocity so the held item rises straight up from among its neighbours, and a pick whose lip
would touch a neighbour on the way down, or whose item has another lying on it, is refused.
A seal that does not form leaves the cup to lift straight up, empty.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import cast

import mujoco
import numpy as np

from planner.errors import PlannerInputError
from planner.motion.clearance import (
    TOUCH_MARGIN_XY,
    Obstacle,
    footprint_distances,
    outline_points_of,
    path_conflicts,
)
from planner.motion.intercept import Intercept, intercept_item
from planner.motion.kinematics import Unreachable
from planner.motion.pick_cycle import PickPlaceConfig
from planner.motion.trajectory import Chain, State
from sim.cell.cell import Cell
from sim.cell.conveyor import rail_top_z
from sim.cell.executor import Playback
from sim.cell.idle_sleep import IdleSleep
from sim.cell.robot import tcp_position
from sim.cell.suction import SuctionConfig, SuctionCup
from sim.flow.catalogue import Catalogue, ItemType

PRESS_DEPTH_M = 0.003
"""The cup aims this far below the item's top so that its lip touches it [m]."""
ON_SHEET_PRESS_M = 0.002
"""How far below its surface the cup aims at an item lying partly on a sheet [m]: pressed
3 mm, a paper scrap lying over an A4 sheet's edge went flat into the sheet (2.4 mm of
contact penetration), and its lift kicked the sheet off the belt at 1.7 m/s (a line's soak,
draw seed 0, episode 17; none at 2 mm); 1 mm was too shallow for a 60 mm cup to seal on a
scrap tilted over a sheet's edge (1.5-2.5 mm sealed)."""
LIP_RING_POINTS = 16
"""Points on the lip's rim at which the item's surface under the cup is measured."""
_RIM_ANGLES = np.linspace(0.0, 2.0 * np.pi, LIP_RING_POINTS, endpoint=False)
_RIM = np.stack([np.cos(_RIM_ANGLES), np.sin(_RIM_ANGLES)], axis=1)  # unit circle, (n, 2)
_DOWN = np.array([0.0, 0.0, -1.0])
TILTED_SURFACE_M = 1e-3
"""The cup aims at the item's surface under its lip, not the item's highest point, where that
surface lies this much lower (a tilted item, one leaning on another) [m]."""
LIES_ON_DZ_M = 1e-3
"""Of two items whose outlines overlap, the one whose centre is this much higher lies on the
other [m]."""
TOUCH_GAP_M = 0.005
"""A neighbour whose outline comes this close to the item's lies against its edge [m]: lifting
the item would catch it if it is higher and round and lying (`PickController.overhangs`: a flat
sheet's corner under a lying bottle's flank, their outlines 0.03 mm apart, flung the bottle into
the held sheet's way), or higher and the item a sheet (`SHEET_TOP_M`), so such a pick waits
until the neighbour is gone. Items the flow drops lie at least 5 mm apart unless they shift."""
SHEET_TOP_M = 0.006
"""An item whose top is at most this high over the belt is a sheet [m] (paper, a folded sheet:
2-4 mm): a higher neighbour within `TOUCH_GAP_M` of its outline may rest its rim on the sheet's
edge, their outlines apart by a fraction of a millimetre or touching (a foil tray's rim on an
A4 sheet's edge went up with the sheet and off the belt at 1.7 m/s, a line's soak, draw seed
0), so the sheet waits for it too, as for a round item lying against an edge."""
DEFAULT_TOP_Z = 0.02
"""Assumed top of an item when no item is found near the detection [m]."""
NEAR_M = 0.08
"""Radius within which the item under a detection is looked for [m]."""
RELEASE_CLEAR_S = 0.06
"""The cup stays still this long after the release so that the falling item clears its lip
(about 2 cm of fall) before the next move starts sideways [s]."""
CLEARANCE_M = 0.025
"""Gap kept between a held item's bottom and the rails, the tallest item on the belt or a
bin's rim [m]."""
APPROACH_CLEARANCE_M = 0.025
"""Gap kept between the empty cup's lip and the top of a neighbour it would pass on the way
down to the item it picks [m]."""
MAX_RAISES = 3
"""Times the approach is planned again over a neighbour the last plan passed too low."""


STARTED_KEPT = 1000
"""Picks started that a controller keeps as planned (`PickController.started`, which the
cycle-time fit reads): every pick of an episode of a few minutes, and a shift's memory flat."""


def clear_height(catalogue: Catalogue, rail_top: float, items: Iterable[ItemType] = ()) -> float:
    """Height [m] a held item's bottom keeps above the belt once lifted: over the rails and
    over the tallest item standing on the belt, catalogue types at their nominal size and
    `items` (the episode's own, scaled: `Flow.item_types`) alike (a held item swept lower
    knocks standing cans off the belt), plus `CLEARANCE_M`."""
    tallest = max(2.0 * t.rest_height for t in (*catalogue.types, *items))
    return max(rail_top, tallest) + CLEARANCE_M


@dataclass(frozen=True)
class StartedPick:
    """A pick as planned when it started (what the planners' cycle-time model predicts).

    Attributes:
        start_xyz: TCP at rest where the pick started [m].
        item_xy: The item's position when the pick was planned [m].
        bin_class: Material class of the destination bin (2..4).
        contact_time: Start to the cup's contact with the item (waiting included) [s].
        cycle_time: Start until the cup may move on after the release (the chain, then
            `RELEASE_CLEAR_S`) [s].
    """

    start_xyz: tuple[float, float, float]
    item_xy: tuple[float, float]
    bin_class: int
    contact_time: float
    cycle_time: float


@dataclass(frozen=True)
class PickOutcome:
    """What one pick attempt did.

    Attributes:
        t_start: Sim time the attempt started [s].
        t_end: Sim time the release ended [s].
        item_id: Flow id of the item the cup held (-1: none).
        sealed: The cup sealed on an item.
        held_to_bin: The item was still held when released over the bin.
    """

    t_start: float
    t_end: float
    item_id: int
    sealed: bool
    held_to_bin: bool


@dataclass(frozen=True, eq=False)
class _Surroundings:
    """The item a pick aims at and its neighbours, measured when the pick is planned.

    Attributes:
        top: The item's highest point [m] (`DEFAULT_TOP_Z` when no item is near).
        yaw: Its heading [rad].
        meets: Height at which the lip, coming straight down, first touches it [m].
        neighbours: (slot, obstacle) of the other items over the belt.
        overlaps: (slot, its centre's height over the item's [m]) of the neighbours whose
            outline overlaps the item's.
        touching: The same of those within `TOUCH_GAP_M` of its outline.
    """

    top: float
    yaw: float
    meets: float
    neighbours: list[tuple[int, Obstacle]]
    overlaps: list[tuple[int, float]]
    touching: list[tuple[int, float]]

    @property
    def under(self) -> set[int]:
        """Slots of the neighbours the item lies on (the top of a pile is picked first)."""
        return {slot for slot, dz in self.overlaps if dz < -LIES_ON_DZ_M}

    def below_lip(self) -> list[Obstacle]:
        """The neighbours that stop the pick on its last way down: the lip meets the item first
        and seals on it, so a neighbour no higher than where it meets the item is pressed at
        most as deep as the item (`PRESS_DEPTH_M`); only a higher one stops it, the lip resting
        on it short of the item. (Refusing the lower one too left two items lying side by side
        refusing each other until both passed.)"""
        under = self.under
        return [o for slot, o in self.neighbours if slot not in under and o.top > self.meets]


@dataclass(frozen=True, eq=False)
class _Aim:
    """Where a pick seals and lets go: the TCP's height at contact `pick_z` [m], the lift
    height [m], the release point `drop` [m] and axis 4's turn on the way [rad]."""

    pick_z: float
    lift: float
    drop: np.ndarray
    turn: float


def _refusal(reason: str) -> Intercept:
    return Intercept(False, reason, float("nan"), np.full(3, np.nan))


class PickController:
    """Plans and executes picks on a `Cell`.

    Args:
        cell: The compiled cell (robot, pool, executor).
        belt_speed: Belt speed [m/s].
        pick_pause: Extra dwell after the seal, riding with the item [s].
        place_pause: Extra dwell over the bin after the release [s].
        items: The episode's items (scaled types), so the lift clears the tallest of them.
        suction: The cup's vacuum settings; `SuctionConfig()` when None.
        robot: Index of the cell's robot this controller drives (`Cell.robots`, 0 upstream):
            its axis 4, TCP, cup, trajectory generator, executor and bins.
        idle_sleep: Let the robot sleep in MuJoCo while it is idle (`sim.cell.idle_sleep`).
    """

    def __init__(
        self,
        cell: Cell,
        belt_speed: float,
        pick_pause: float = 0.0,
        place_pause: float = 0.0,
        items: Iterable[ItemType] = (),
        suction: SuctionConfig | None = None,
        *,
        robot: int = 0,
        idle_sleep: bool = False,
    ):
        self.cell = cell
        self.view = cell.robots[robot]
        """The robot driven (`sim.cell.robots.RobotView`)."""
        self.prefix = prefix = self.view.prefix
        self.sleep = IdleSleep(cell.model, cell.data, prefix, idle_sleep)
        self.belt_speed = float(belt_speed)
        base = PickPlaceConfig()
        # Extra dwell (the thesis's pauses): the cup rides with the item after the seal, and
        # stays over the bin after the release.
        self.config = replace(
            base,
            seal_time=base.seal_time + pick_pause,
            release_time=base.release_time + place_pause,
        )
        self.suction = SuctionCup(cell.model, cell.pool, suction, prefix=prefix)
        mujoco.mj_forward(cell.model, cell.data)
        self.rest = tcp_position(cell.model, cell.data, prefix=prefix)
        self.axis4 = float(cell.data.joint(f"{prefix}axis4_joint").qpos[0])
        self.plan_failures = 0
        self.raises = 0  # approaches planned again over a neighbour
        self.neighbour_refusals = 0  # picks refused: a neighbour in the cup's way down
        self.clear_z = clear_height(cell.catalogue, rail_top_z(cell.model), items)
        self.belt_top_z = float(cell.pool.belt.geometry.top_z)
        self._pick: _PickInProgress | None = None
        self._request: tuple[float, float, int] | None = None
        self._planned: tuple | None = None  # (chain, playback) of the last feasible plan
        self._planned_slot: int | None = None  # the slot `plan` aimed at last
        self.aimed_slot: int | None = None
        """Pool slot of the item the pick under way aims at (None: idle)."""
        self.aimed_by_others: Callable[[], Iterable[int]] = tuple
        """The slots the other robots' picks under way aim at (a line sets it:
        `sim.episode.builder.pick_controllers`); an item touching one of them waits."""
        self.started: deque[StartedPick] = deque(maxlen=STARTED_KEPT)
        """The picks started, as planned: the last `STARTED_KEPT`."""
        self.halted = False
        """A protective stop holds the robot: its set-points stay, its pick waits (`halt`)."""

    def slot_near(self, x: float, y: float) -> int | None:
        """Pool slot of the item on the belt nearest (x, y) now, within `NEAR_M`, or None."""
        items = self.cell.items
        slots = items.active_slots()
        centres = items.positions(slots)
        d = np.hypot(centres[:, 0] - x, centres[:, 1] - y)
        # The first of the nearest (as a scan keeping the strictly nearer one would find).
        d = np.where((d < NEAR_M) & (centres[:, 2] > -0.05), d, np.inf)
        if not d.size:
            return None
        k = int(np.argmin(d))
        return int(slots[k]) if d[k] < np.inf else None

    def item_shape(self, slot: int | None) -> tuple[float, float]:
        """(top height [m], heading [rad]) of the item in `slot` (`slot_near` a detection) now.

        The stand-in for what a stereo camera (the thesis's ZED) measures of an item's shape:
        read from the simulation in both perception modes. (DEFAULT_TOP_Z, 0) when no item
        is near (`slot` None).
        """
        if slot is None:
            return DEFAULT_TOP_Z, 0.0
        xmat = self.cell.items.orientation(slot)
        return self.top_of(slot), float(np.arctan2(xmat[3], xmat[0]))  # heading of body x

    def lip_meets(self, slot: int, x: float, y: float, top: float) -> float:
        """Height [m] at which the lip, coming straight down centred on (x, y) [m], first
        touches the item in `slot`: the highest point of the item's surface under the lip's rim
        and centre (a ray cast straight down onto the item's geom at each point), or `top`, its
        highest point, where the surface under the lip is within `TILTED_SURFACE_M` of it (a
        flat item; the lip presses `PRESS_DEPTH_M` into it anyway).

        The highest corner of a folded sheet tilted by 15 degrees (lying half on another item)
        is 5.5 mm above where the lip meets it: a cup aimed at the corner stopped 2.5 mm above
        the sheet, never sealed, and failed every attempt.
        """
        model = self.cell.model
        geom = self.cell.pool.geom_id(slot)
        pos, mat = self.cell.items.geom_pose(slot)
        size, kind = model.geom_size[geom], int(model.geom_type[geom])
        start_z = top + 0.05
        starts = np.empty((LIP_RING_POINTS + 1, 3))
        starts[0, :2] = x, y  # the centre, then the rim
        starts[1:, :2] = (x, y) + self.suction.radius * _RIM
        starts[:, 2] = start_z
        hits = [
            start_z - dist
            for start in starts
            if (dist := mujoco.mju_rayGeom(pos, mat, size, start, _DOWN, kind)) >= 0.0
        ]
        if not hits or top - max(hits) < TILTED_SURFACE_M:
            return top
        return float(max(hits))

    def neighbours(self, exclude: int | None) -> list[tuple[int, Obstacle]]:
        """(slot, obstacle) of the items over the belt but `exclude` (a slot), measured now
        (the same stand-in for a stereo camera as `item_shape`)."""
        items = self.cell.items
        belt = self.cell.pool.belt.geometry
        slots = items.active_slots()
        centres = items.positions(slots)
        # Items over the belt only: one just let go of over a bin is falling into it.
        over = belt.on_belt(centres[:, :2]) & ~(centres[:, 2] < belt.top_z - 0.05)
        return [(int(s), self.obstacle_of(int(s))) for s in slots[over] if s != exclude]

    def obstacle_of(self, slot: int) -> Obstacle:
        """The item in `slot` as the cup's obstacle: its outline seen from above and its top."""
        model = self.cell.model
        geom = self.cell.pool.geom_id(slot)
        pos, mat = self.cell.items.geom_pose(slot)
        cx, cy = (float(v) for v in pos[:2])
        rot = mat.reshape(3, 3)
        size = model.geom_size[geom]
        top = self._top(geom, pos, mat)
        if model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_BOX:
            # Its own x-y rectangle, grown by its thickness when tilted (a conservative outline
            # of the projection).
            tilt = float(np.sqrt(max(0.0, 1.0 - rot[2, 2] ** 2)))
            heading = float(np.arctan2(rot[1, 0], rot[0, 0]))
            return Obstacle(cx, cy, heading, size[0], size[1], size[2] * tilt, top)
        # Cylinder or capsule: its axis seen from above, grown by its radius.
        ax, ay = rot[0, 2], rot[1, 2]
        half = float(size[1] * np.hypot(ax, ay))
        return Obstacle(cx, cy, float(np.arctan2(ay, ax)), half, 0.0, float(size[0]), top)

    def resting_on(self, target: int, neighbours: list[tuple[int, Obstacle]]) -> list[int]:
        """Slots of the neighbours lying on or leaning against the item in `target`: their
        outlines overlap and their centre is higher. Lifting the item at the cup's 100 m/s^2
        would fling them (a standing can on a board's edge left it at 2.7 m/s)."""
        return [slot for slot, dz in self._overlapping(target, neighbours) if dz > LIES_ON_DZ_M]

    def lying_under(self, target: int, neighbours: list[tuple[int, Obstacle]]) -> list[int]:
        """Slots of the neighbours the item in `target` lies on or leans against: their
        outlines overlap and their centre is lower. The top item of a pile is picked first;
        the cup pressing it may touch the one beneath, which it lies on anyway."""
        return [slot for slot, dz in self._overlapping(target, neighbours) if dz < -LIES_ON_DZ_M]

    def _overlapping(
        self, target: int, neighbours: list[tuple[int, Obstacle]], gap: float = 0.0
    ) -> list[tuple[int, float]]:
        """(slot, its centre's height over the target's [m]) of the neighbours whose outline
        the target's outline overlaps, or comes within `gap` [m] of (touching edge to edge)."""
        return [(slot, dz) for slot, dz, d in self._outline_gaps(target, neighbours) if d <= gap]

    def _outline_gaps(
        self, target: int, neighbours: list[tuple[int, Obstacle]]
    ) -> list[tuple[int, float, float]]:
        """(slot, its centre's height over the target's [m], the gap between their outlines
        [m], 0 where they overlap) of every neighbour.

        Measured both ways: the target's outline points against each neighbour's footprint,
        and each neighbour's points against the target's (a tray's corner poking 2 mm over an
        A4 sheet's edge lies between the sheet's points, 3.7 cm apart, and was missed)."""
        if not neighbours:
            return []
        own = self.obstacle_of(target)
        items = self.cell.items
        z = items.position(target)[2]
        obstacles = [o for _, o in neighbours]
        outlines = outline_points_of([own, *obstacles])  # (1 + k, m, 2), each as alone
        points, stacked = outlines[0], outlines[1:].reshape(-1, 2)
        near = footprint_distances(obstacles, points, np.zeros(len(points))).min(axis=1)
        starts = np.arange(len(obstacles)) * outlines.shape[1]
        back = footprint_distances([own], stacked, np.zeros(len(stacked)))[0]
        near = np.minimum(near, np.minimum.reduceat(back, starts))
        heights = items.positions(np.array([slot for slot, _ in neighbours]))[:, 2] - z
        return [
            (slot, float(dz), float(distance))
            for (slot, _), dz, distance in zip(neighbours, heights, near, strict=True)
        ]

    def _neighbours_forbid(
        self,
        target: int | None,
        overlaps: list[tuple[int, float]],
        touching: list[tuple[int, float]],
    ) -> str | None:
        """Why the item in `target` may not be lifted now because of its neighbours (None: it
        may), from the neighbours overlapping its outline and those touching it, each with its
        centre's height over the target's [m]."""
        if target is None:
            return None
        sheet = self.top_of(target) - self.belt_top_z <= SHEET_TOP_M
        on_edge = [s for s, dz in touching if dz > LIES_ON_DZ_M and (sheet or self.overhangs(s))]
        if on_edge or any(dz > LIES_ON_DZ_M for _, dz in overlaps):
            return "a higher item lies on it or against its edge (lifting it would fling that one)"
        aimed = set(self.aimed_by_others())
        if aimed and any(slot in aimed for slot, _ in touching):
            # Two cups over items that touch: whichever lifts first drags the other's target
            # from under its cup (or flings it). This one waits; the other robot's pick goes on.
            return "another robot is picking an item touching it"
        return None

    def overhangs(self, slot: int) -> bool:
        """Whether the item in `slot` is round and lying (a capsule or cylinder whose axis is
        more than 45 degrees from vertical): its flank curves out over the belt, so an item
        touching its outline lies partly under it (a box or a standing can has upright sides)."""
        kind = int(self.cell.model.geom_type[self.cell.pool.geom_id(slot)])
        if kind not in (int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_CYLINDER)):
            return False
        _, mat = self.cell.items.geom_pose(slot)
        return abs(float(mat[8])) < math.cos(math.pi / 4)

    def top_of(self, slot: int) -> float:
        """Highest point [m] of the item in `slot` as it lies now (a can may have toppled)."""
        geom = self.cell.pool.geom_id(slot)
        return self._top(geom, *self.cell.items.geom_pose(slot))

    def _top(self, geom: int, pos: np.ndarray, mat: np.ndarray) -> float:
        """`top_of` the item whose geom `geom` lies at `pos` [m] turned by `mat` (row-major)."""
        model = self.cell.model
        z = float(pos[2])
        up = mat.reshape(3, 3)[2]  # world z in the geom's axes
        size = model.geom_size[geom]
        kind = model.geom_type[geom]
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            return z + float(np.abs(up) @ size)
        across = float(np.sqrt(max(0.0, 1.0 - up[2] ** 2)))  # cylinder, capsule: axis = geom z
        if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
            return z + float(size[1] * abs(up[2]) + size[0])
        return z + float(size[1] * abs(up[2]) + size[0] * across)

    def plan(self, x: float, y: float, bin_class: int) -> Intercept:
        """Intercept of an item now at (x, y) [m], carried to the bin of `bin_class`.

        The item hangs under the cup by its height (its top is where the cup seals), so the
        lift and the release point keep its bottom at `clear_height` (over the rails and the
        tallest item on the belt; the bins' rims are lower); axis 4 turns the item's long axis
        along the bin's long side.

        The items around it are measured too (`neighbours`), and the plan is checked against
        them as they ride on (`planner.motion.clearance`): where the empty cup would pass a
        neighbour too low on its way, the corner above the item is raised over that
        neighbour's top (`APPROACH_CLEARANCE_M`) and the pick planned again, so the cup comes
        down straight from above it. The pick is refused, with the reason, when the lip would
        touch a neighbour higher than the item on the last way down (an item this one lies on
        aside: the top of a pile is picked first; of two items side by side the higher one is),
        or another item lies on this one.
        """
        self._request = (float(x), float(y), int(bin_class))
        target = self._planned_slot = self.slot_near(x, y)
        around = self._surroundings(target, x, y)
        reason = self._neighbours_forbid(target, around.overlaps, around.touching)
        if reason:
            self.neighbour_refusals += 1
            return _refusal(reason)
        return self._plan_clear_of((x, y), around, self._aim(around, bin_class))

    def _surroundings(self, target: int | None, x: float, y: float) -> _Surroundings:
        """The item in `target` (None: none near the detection at (x, y) [m]) and its
        neighbours, measured now."""
        top, yaw = self.item_shape(target)
        # Where the lip comes down onto the item: its highest point, or, on a tilted item, its
        # surface under the lip (a tilted sheet's highest corner is millimetres above it).
        meets = self.lip_meets(target, x, y, top) if target is not None else top
        neighbours = self.neighbours(exclude=target)
        gaps = self._outline_gaps(target, neighbours) if target is not None else []
        return _Surroundings(
            top, yaw, meets, neighbours,
            overlaps=[(slot, dz) for slot, dz, d in gaps if d <= 0.0],
            touching=[(slot, dz) for slot, dz, d in gaps if d <= TOUCH_GAP_M],
        )  # fmt: skip

    def _axis4_turn(self, yaw: float) -> float:
        """Axis 4's turn [rad] on the way, so the item's long axis (heading `yaw` [rad]) ends
        along the bins' long side (x). An item looks the same turned by pi: of the turns that
        align it, the one that ends axis 4 nearest zero, so its angle never drifts into the
        joint's +-pi limit."""
        turn = -float(np.arctan2(np.sin(yaw), np.cos(yaw)))
        turn = (turn + np.pi / 2) % np.pi - np.pi / 2
        return min((turn + k * np.pi for k in (-1, 0, 1)), key=lambda a: abs(self.axis4 + a))

    def _aim(self, around: _Surroundings, bin_class: int) -> _Aim:
        """Where the cup seals on the item, how high it lifts it and where it lets it go."""
        # An item lying partly on a sheet is pressed only as deep as `ON_SHEET_PRESS_M`: pressed
        # flat, it drove its edge into the sheet's and the lift kicked the sheet off the belt.
        on_sheet = any(self.top_of(s) - self.belt_top_z <= SHEET_TOP_M for s in around.under)
        pick_z = max(around.meets - (ON_SHEET_PRESS_M if on_sheet else PRESS_DEPTH_M), 0.0)
        height = max(around.top, 0.0)
        lift = max(self.config.lift_height, self.clear_z + height - pick_z)
        drop = np.array(self.view.drop_xyz[bin_class], dtype=float)
        # Long items overhang the bin towards the belt: keep them above the rails too.
        drop[2] = max(drop[2], self.clear_z + height)
        return _Aim(pick_z, lift, drop, self._axis4_turn(around.yaw))

    def _plan_clear_of(
        self, item_xy: tuple[float, float], around: _Surroundings, aim: _Aim
    ) -> Intercept:
        """The intercept whose empty cup passes every neighbour, the corner above the item
        raised over those passed too low (at most `MAX_RAISES` times); refused when the lip
        would land on a neighbour higher than where it meets the item."""
        obstacles = [o for _, o in around.neighbours]
        below_lip = around.below_lip()
        approach = self.config.approach_height
        for _ in range(MAX_RAISES + 1):
            config = replace(
                self.config,
                lift_height=aim.lift,
                approach_height=approach,
                # The vacuum switch holds the cup on the item until the seal is made.
                seal_time=self.config.seal_time + self.suction.seal_delay,
            )
            try:
                hit = intercept_item(
                    State.at_rest(self.rest), item_xy, self.belt_speed,
                    cast(Sequence[float], aim.drop),  # an array: the planner indexes it
                    self.view.generator, aim.pick_z, config,
                    axis4=(self.axis4, self.axis4 + aim.turn),
                )  # fmt: skip
            except PlannerInputError as exc:
                self.plan_failures += 1
                return _refusal(str(exc))
            if not hit.feasible:
                return hit
            assert hit.plan is not None  # a feasible intercept asked with its plan has one
            chain, radius = hit.plan.chain, self.suction.radius
            t_down = chain.phase_start("descend")
            # The way down onto the item, nearly vertical: only a neighbour the lip would
            # touch stops the pick (no corner height helps).
            conflicts = path_conflicts(
                chain, hit.plan.contact_time, below_lip, self.belt_speed, radius,
                margin_xy=TOUCH_MARGIN_XY, margin_z=0.0, t_start=t_down,
            )  # fmt: skip
            if conflicts:
                break
            # The flight to the corner above the item: a neighbour passed too low or too close
            # is flown over instead (the corner raised over its top), then straight down.
            conflicts = path_conflicts(chain, t_down, obstacles, self.belt_speed, radius)
            if not conflicts:
                return self._playable(hit)
            need = max(c.top for c in conflicts) + APPROACH_CLEARANCE_M - aim.pick_z
            if need <= approach + 1e-6:
                break
            approach = need
            self.raises += 1
        self.neighbour_refusals += 1
        c = max(conflicts, key=lambda c: c.top - c.cup_z)
        return _refusal(
            f"the cup would pass {c.gap * 1e3:.0f} mm beside a neighbour whose top is "
            f"{c.top - c.cup_z:+.3f} m above the lip"
        )

    def _playable(self, hit: Intercept) -> Intercept:
        """`hit` if the executor can play its plan, else refused. The planner checks the path
        every `CHECK_DT` (2 ms); the executor's set-points, one each control period (1 ms), may
        find a point between two checks outside the workspace, at its very edge: such a pick
        is refused now, before any robot commits to it. The playback made here is the one
        `start` plays."""
        assert hit.plan is not None  # `_plan_clear_of` hands over feasible, planned hits
        try:
            playback = self.view.executor.playback(hit.plan.chain, hold=RELEASE_CLEAR_S)
        except Unreachable as exc:
            self.plan_failures += 1
            return Intercept(False, f"the path leaves the workspace: {exc}", math.nan, hit.pick_xyz)
        self._planned = (hit.plan.chain, playback)
        return hit

    @property
    def busy(self) -> bool:
        """A pick is under way (from `start` until `poll` returns its outcome)."""
        return self._pick is not None

    def start(self, intercept: Intercept, target: int = -1) -> None:
        """Begin playing a feasible intercept's plan from the current sim time.

        The vacuum opens as the descent starts (the cup seals once its lip has touched the item
        for the seal time) and closes when the cup reaches the drop point (the item falls the
        release time later, at the end of the chain). The episode's loop then calls
        `before_step` and `after_step` around each physics step and `poll` after its other
        after-step work, until `poll` returns the outcome.

        Args:
            intercept: A feasible intercept with its plan.
            target: Flow id of the item aimed at, when known (for `activity`).
        """
        plan = intercept.plan
        assert plan is not None, "start needs a feasible intercept with its plan"
        x, y, bin_class = self._request if self._request is not None else (np.nan, np.nan, 0)
        self.started.append(
            StartedPick(
                start_xyz=cast(tuple[float, float, float], tuple(float(c) for c in self.rest)),
                item_xy=(x, y),
                bin_class=bin_class,
                contact_time=float(plan.contact_time),
                cycle_time=float(plan.chain.duration) + RELEASE_CLEAR_S,
            )
        )
        self.sleep.busy()
        self.aimed_slot, self._planned_slot = self._planned_slot, None
        playback = self._playback_of(plan.chain)
        self._pick = _PickInProgress(
            chain=plan.chain,
            target=int(target),
            playback=playback,
            times=playback.times.tolist(),
            vacuum_from=plan.chain.phase_start("descend"),
            release_time=plan.release_time,
            t_start=float(self.cell.data.time),
            end=plan.chain.at_time(plan.chain.duration)[0],
        )

    def _playback_of(self, chain) -> Playback:
        """The playback of `chain`: the one `plan` made for it, else made now."""
        planned, self._planned = self._planned, None
        if planned is not None and planned[0] is chain:
            return planned[1]
        return self.view.executor.playback(chain, hold=RELEASE_CLEAR_S)

    def activity(self) -> str:
        """What the robot is doing now, in a few words (for logs of unexpected events)."""
        pick = self._pick
        if pick is None:
            return "idle"
        if pick.k >= pick.playback.n:
            phase = "releasing"
        else:
            t = float(pick.playback.times[max(pick.k - 1, 0)])
            i = int(np.searchsorted(pick.chain.starts, t, side="right")) - 1
            phase = pick.chain.segments[min(max(i, 0), len(pick.chain.segments) - 1)].label
        held = self.suction.held_item
        return (
            f"pick of item {pick.target}: {phase}, "
            f"{'holding item ' + str(held) if held is not None else 'holding nothing'}"
        )

    def halt(self) -> None:
        """A protective stop: the motors hold the last set-points, the cup keeps its vacuum
        (an item held stays held), the pick under way waits (`resume`)."""
        self.halted = True

    def resume(self, t: float) -> bool:
        """The end of a protective stop at sim time `t` [s]. True when the pick under way goes
        on (the cup holds its item, or the release has begun) or there is none; False when it
        was given up (not sealed: its item has ridden on), the robot now at rest where it
        stopped, from where it plans its next pick."""
        self.halted = False
        pick, cup = self._pick, self.suction
        if pick is None or cup.held_slot is not None or pick.vacuum_off:
            return True
        cup.vacuum_off(t)
        self._pick, self.aimed_slot = None, None
        self.sleep.idle()
        data = self.cell.data
        self.rest = tcp_position(self.cell.model, data, prefix=self.prefix)
        self.axis4 = float(data.joint(f"{self.prefix}axis4_joint").qpos[0])
        return False

    def before_step(self) -> None:
        """Set-points of the coming control period (none once the chain has been played, nor
        while halted: the motors hold the last)."""
        pick = self._pick
        if pick is not None and pick.k < pick.playback.n and not self.halted:
            pick.playback.apply(pick.k)

    def after_step(self) -> bool:
        """The cup after a physics step: vacuum on at the descent, off at the drop point.

        Returns whether the loop must look at the pick before the next step: the cup did
        something (sealed, lost or released an item), or the chain has been played (`poll`).
        """
        pick, data, cup = self._pick, self.cell.data, self.suction
        if pick is None:
            return False
        if pick.k < pick.playback.n and not self.halted:
            t_traj = pick.times[pick.k]
            pick.k += 1
            if not pick.vacuum_on and t_traj >= pick.vacuum_from:
                cup.vacuum_on()
                pick.vacuum_on = True
            if not pick.vacuum_off and t_traj >= pick.release_time:
                cup.vacuum_off(float(data.time))
                pick.vacuum_off = True
        if cup.active:  # else `update` changes nothing
            events = cup.update(data)
            if events:
                pick.events.extend(events)
                return True
        return pick.k >= pick.playback.n and not self.halted

    def poll(self) -> PickOutcome | None:
        """The outcome once the chain has been played and the cup has let go, else None."""
        pick, cup = self._pick, self.suction
        if pick is None or pick.k < pick.playback.n or self.halted:
            return None
        if not pick.vacuum_off:
            cup.vacuum_off(float(self.cell.data.time))
            pick.vacuum_off = True
        if cup.held_slot is not None:  # finish the release (normally already done)
            return None
        self._pick = None
        self.aimed_slot = None
        self.sleep.idle()
        sealed = [e for e in pick.events if e.kind == "sealed"]
        item_id = sealed[0].item_id if sealed else -1
        released = any(e.kind == "released" and e.item_id == item_id for e in pick.events)
        self.rest = np.asarray(pick.end[:3], dtype=float)
        self.axis4 = float(pick.end[3])
        t_end = float(self.cell.data.time)
        return PickOutcome(pick.t_start, t_end, item_id, bool(sealed), released)


@dataclass
class _PickInProgress:
    """The state of one pick while the loop plays it (period index, vacuum switches, events)."""

    chain: Chain
    target: int
    playback: Playback
    times: list[float]  # the playback's period ends [s], as Python floats (read every step)
    vacuum_from: float
    release_time: float
    t_start: float
    end: np.ndarray
    k: int = 0
    vacuum_on: bool = False
    vacuum_off: bool = False
    events: list = field(default_factory=list)
