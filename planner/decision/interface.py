"""The decision managers' interface: tracked items, robot state, context, choice, protocols.

A decision manager takes the items tracked on the belt (position at the decision time and class
probabilities over void and the materials: paper, plastic, aluminium by default, or a
catalogue's own), the robot's state and a context (belt speed, one bin and one value per
material, cycle-time model, reachable window) and returns the next item to pick, or None.
Material class ids are 2, 3, ... in the materials' order (1 is void); the context's `bins` and
`values` follow that order.

Expected value: an item goes to the bin of its most probable material class c; it earns the
value of c only when its true class is c (a wrong bin earns nothing), so its expected value is
p(c) * value(c). A confident aluminium thus outranks an uncertain one; truth mode passes
one-hot probabilities and the expected value is the class value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

from perception.codes import (
    MATERIALS,
    MAX_MATERIALS,
    THESIS_VALUES_EUR,
)
from planner.decision.energy_cost import EnergyPrice
from planner.errors import PlannerInputError
from planner.motion.reach_window import ReachWindow

THESIS_VALUES = THESIS_VALUES_EUR
# A stand-alone default for the planner's own tests (paper on -y, plastic and aluminium on +y):
# approximately the cell's release points. Every context the cell builds passes the positions of
# the sites bin_<class>_drop read from the compiled model instead.
DEFAULT_BINS = ((0.0, -0.51, 0.06), (-0.21, 0.51, 0.06), (0.21, 0.51, 0.06))
BELT_HALF_WIDTH = 0.4
"""Half the thesis's belt width [m] (a cell's context passes its model's)."""


@runtime_checkable
class CycleTimeEstimator(Protocol):
    """Durations of the robot's moves, the physics the planners plan with."""

    def time_to_pick(self, start_xyz, item_xy, belt_speed: float) -> float:
        """Time from `start_xyz` until the cup meets an item now at `item_xy` moving at +x [s]."""

    def time_to_place(self, pick_xyz, bin_xyz) -> float:
        """Time from the pick point until the item is released over the bin [s]."""


@dataclass(frozen=True)
class TrackedItem:
    """An item on the belt as the tracker sees it at the decision time.

    Attributes:
        item_id: Identifier, unique within an episode.
        x: Position along the belt at the decision time [m].
        y: Position across the belt [m].
        class_probs: (1 + m,) probabilities over void and the m materials (sum 1): void,
            paper, plastic, aluminium for the thesis's.
    """

    item_id: int
    x: float
    y: float
    class_probs: tuple[float, ...]
    _bin_class: int = field(init=False, repr=False, compare=False)  # set by __post_init__

    def __post_init__(self):
        # Plain Python, not numpy: a line's decisions build about a million of these.
        try:
            probs_t = tuple(float(p) for p in self.class_probs)
        except (TypeError, ValueError):
            probs_t = ()
        ok = 2 <= len(probs_t) <= MAX_MATERIALS + 1
        if not ok or not all(math.isfinite(p) and p >= 0.0 for p in probs_t):
            allowed = f"2..{MAX_MATERIALS + 1} finite probabilities >= 0 (void, materials)"
            raise PlannerInputError("class_probs", allowed, self.class_probs)
        if abs(math.fsum(probs_t) - 1.0) > 1e-6:
            raise PlannerInputError("class_probs", "probabilities summing to 1", sum(probs_t))
        if not (math.isfinite(self.x) and math.isfinite(self.y)):
            raise PlannerInputError("x, y", "finite positions [m]", (self.x, self.y))
        object.__setattr__(self, "class_probs", probs_t)
        materials = probs_t[1:]
        object.__setattr__(self, "_bin_class", 2 + materials.index(max(materials)))

    @classmethod
    def certain(
        cls, item_id: int, x: float, y: float, class_code: int, n_materials: int = len(MATERIALS)
    ) -> TrackedItem:
        """An item of known class (truth mode); `class_code` 1 (void) or 2..1+n_materials."""
        if not 1 <= class_code <= 1 + n_materials:
            raise PlannerInputError(
                "class_code", f"1..{1 + n_materials} (void, the materials)", class_code
            )
        probs = [0.0] * (1 + n_materials)
        probs[class_code - 1] = 1.0
        return cls(item_id, float(x), float(y), tuple(probs))

    def at(self, x: float, y: float) -> TrackedItem:
        """The same item at position (`x`, `y`) [m]: equal to a `TrackedItem` made anew with
        these positions, without checking its probabilities again (they were when it was made;
        a tracker re-positions every item at every decision)."""
        if not (math.isfinite(x) and math.isfinite(y)):
            raise PlannerInputError("x, y", "finite positions [m]", (x, y))
        moved = object.__new__(type(self))
        moved.__dict__.update(self.__dict__, x=x, y=y)
        return moved

    @property
    def bin_class(self) -> int:
        """Most probable material class (2, 3, ...): the bin the item goes to."""
        return self._bin_class


@dataclass(frozen=True)
class RobotState:
    """The robot when a decision is due: TCP position [m] and clock [s]."""

    tcp: tuple[float, float, float]
    time: float

    def __post_init__(self):
        tcp = tuple(float(c) for c in self.tcp)
        if len(tcp) != 3 or not all(math.isfinite(c) for c in tcp):
            raise PlannerInputError("tcp", "3 finite coordinates [m]", self.tcp)
        if not math.isfinite(self.time):
            raise PlannerInputError("time", "a finite clock [s]", self.time)
        object.__setattr__(self, "tcp", tcp)


@dataclass(frozen=True, eq=False)
class DecisionContext:
    """What every decision manager needs besides the items and the robot.

    Attributes:
        belt_speed: Belt speed along +x [m/s].
        cycle_model: Cycle-time estimator (the ruckig-fitted model in real runs).
        window: Where the cup can meet an item on the belt.
        bins: Release points of the materials' bins [m], one (x, y, z) per material (paper,
            plastic, aluminium by default).
        values: Value of an item of each material [EUR] (thesis table 3.3 by default).
        energy: The price of a pick's motor energy (`planner.decision.energy_cost`); at the
            default price 0 no planner sees it.
        belt_half_width: Half the belt's width [m] (the thesis's 0.4 by default), across
            which the thesis's grid spreads its columns (`planner.decision.batch_grid`).
    """

    belt_speed: float
    cycle_model: CycleTimeEstimator
    window: ReachWindow
    bins: tuple[tuple[float, float, float], ...] = DEFAULT_BINS
    values: tuple[float, ...] = THESIS_VALUES
    energy: EnergyPrice = EnergyPrice()
    belt_half_width: float = BELT_HALF_WIDTH

    def __post_init__(self):
        if not (math.isfinite(self.belt_speed) and self.belt_speed >= 0.0):
            raise PlannerInputError("belt_speed", "a finite speed >= 0 [m/s]", self.belt_speed)
        values = tuple(float(v) for v in self.values)
        ok = 1 <= len(values) <= MAX_MATERIALS
        if not ok or not all(math.isfinite(v) and v >= 0.0 for v in values):
            raise PlannerInputError(
                "values", "a finite value >= 0 [EUR] per material (paper, plastic, ...)", values
            )
        bins = tuple(tuple(float(c) for c in b) for b in self.bins)
        if len(bins) != len(values) or any(
            len(b) != 3 or not all(map(math.isfinite, b)) for b in bins
        ):
            raise PlannerInputError("bins", "one (x, y, z) release point per value [m]", self.bins)
        if not isinstance(self.energy, EnergyPrice):
            raise PlannerInputError("energy", "an EnergyPrice", type(self.energy).__name__)
        if not isinstance(self.cycle_model, CycleTimeEstimator):
            raise PlannerInputError("cycle_model", "an object with time_to_pick, time_to_place")
        w = self.belt_half_width
        if not (isinstance(w, int | float) and math.isfinite(w) and w > 0.0):
            raise PlannerInputError("belt_half_width", "a finite half width > 0 [m]", w)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "bins", bins)

    def value_of(self, class_code: int) -> float:
        """Value of one item of material `class_code` (2, 3, ...) [EUR]; void is worth 0."""
        k = class_code - 2
        return self.values[k] if 0 <= k < len(self.values) else 0.0

    def bin_of(self, class_code: int) -> tuple[float, float, float]:
        """Release point of the bin of material `class_code` (2, 3, ...) [m]."""
        return self.bins[class_code - 2]

    @property
    def n_materials(self) -> int:
        """Materials (bins) of the cell."""
        return len(self.values)

    def expected_value(self, item: TrackedItem) -> float:
        """p(bin class) * value(bin class) [EUR]: what dropping the item in its bin earns."""
        c = item.bin_class
        return item.class_probs[c - 1] * self.value_of(c)

    def net_value(self, expected_value, distance_m):
        """Expected value [EUR] net of the energy cost of a pick over the thesis's distance
        `distance_m` (start -> item -> bin) [m]; scalars or arrays."""
        if self.energy.price_eur_per_kwh == 0.0:
            return expected_value
        return expected_value - self.energy.cost_eur(distance_m)

    def with_values(self, values: tuple[float, ...]) -> DecisionContext:
        """The same context with other class values [EUR]."""
        return DecisionContext(
            self.belt_speed,
            self.cycle_model,
            self.window,
            self.bins,
            values,
            self.energy,
            self.belt_half_width,
        )


@dataclass(frozen=True)
class Choice:
    """A decision: which item to pick next and why.

    Attributes:
        expected_value: Its expected value [EUR].
        meet_time: Predicted time the cup meets it [s] (clock of RobotState).
        bin_class: Material class whose bin it goes to (2, 3, ...).
        reason: One line for logs and video overlays.
    """

    item_id: int
    expected_value: float
    meet_time: float
    bin_class: int
    reason: str


class DecisionManager(Protocol):
    """Chooses the next pick; planners may keep state between calls (reset per episode)."""

    name: str

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """The next item to pick among `items`, or None when none is worth or can be picked."""

    def reset(self) -> None:
        """Forget any state kept from earlier calls (start of an episode)."""
