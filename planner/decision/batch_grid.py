"""The thesis's belt grid (sections 3.3, 3.4): rows fixed to the belt, 27 columns, 20-row batches.

The belt is seen as a grid whose rows are one observation period of belt travel apart (row
pitch = belt speed x observation period, 0.0925 m at x1 and 0.5 s) and whose 27 columns are the
25 across the belt (columns 2..26, numbered from 1 as in the thesis) and the two bin columns
(1 and 27). Rows are fixed to the belt: an item keeps its row as it moves. Row 0 is the row of
the first item the planner sees (the start of the thesis's sequence), and rows are counted
upstream from it; the rows are handed to the learner in batches of `batch_rows` (20).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from planner.decision.interface import BELT_HALF_WIDTH as THESIS_BELT_HALF_WIDTH
from planner.decision.interface import TrackedItem
from planner.errors import PlannerInputError

OBJECTIVES = ("v/d", "d=1", "v=1")
"""The thesis's objectives (section 4.1.3): value over distance, value only, distance only."""
MIN_DISTANCE = 1e-3
"""[m] keeps w = v / d finite for an item under the cup."""

BELT_COLUMNS = 25
GRID_COLUMNS = BELT_COLUMNS + 2
BELT_HALF_WIDTH = THESIS_BELT_HALF_WIDTH
"""Half the thesis's belt width the 25 columns span [m]; a context's `belt_half_width` is the
cell's belt's."""


def belt_coordinate(item: TrackedItem, t: float, belt_speed: float) -> float:
    """Where the item was at t = 0 [m]: a coordinate fixed to the belt."""
    return item.x - belt_speed * t


def grid_row(
    item: TrackedItem, t: float, belt_speed: float, row_period_s: float, origin: float = 0.0
) -> int:
    """Row of an item, counted upstream from the belt coordinate `origin` [m] (row 0 holds the
    first item seen); 0 on a stopped belt."""
    if belt_speed <= 0.0:
        return 0
    u = belt_coordinate(item, t, belt_speed)
    return math.floor((origin - u) / (belt_speed * row_period_s))


def batch_index(
    item: TrackedItem,
    t: float,
    belt_speed: float,
    row_period_s: float,
    batch_rows: int,
    origin: float = 0.0,
) -> int:
    """Batch of an item: its grid row // batch_rows (see `grid_row`)."""
    return grid_row(item, t, belt_speed, row_period_s, origin) // batch_rows


def grid_column(y: float, half_width: float = BELT_HALF_WIDTH) -> int:
    """Grid column 2..26 of a belt position y [m] (1 and 27 are the bin columns)."""
    k = int((y + half_width) / (2 * half_width) * BELT_COLUMNS)
    return 2 + min(max(k, 0), BELT_COLUMNS - 1)


def column_centre(column: int, half_width: float = BELT_HALF_WIDTH) -> float:
    """y [m] of the centre of grid column 2..26."""
    return -half_width + (column - 1.5) * (2 * half_width / BELT_COLUMNS)


def _number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def check_learning_parameters(
    gamma, iterations, batch_rows, row_period_s, objective, tolerance
) -> None:
    """Refuse (`PlannerInputError`, naming the field) the thesis's learning parameters out of
    range: gamma in [0, 1), iterations and batch rows integers >= 1, a row period > 0 [s], one
    of `OBJECTIVES`, a tolerance >= 0. Shared by the Q-learning and the rollout planner."""
    if not (_number(gamma) and 0.0 <= gamma < 1.0):
        raise PlannerInputError("gamma", "a number in [0, 1)", gamma)
    for name, value in (("iterations", iterations), ("batch_rows", batch_rows)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise PlannerInputError(name, "an integer >= 1", value)
    if not (_number(row_period_s) and row_period_s > 0.0):
        raise PlannerInputError("row_period_s", "a period > 0 [s]", row_period_s)
    if objective not in OBJECTIVES:
        raise PlannerInputError("objective", " | ".join(OBJECTIVES), objective)
    if not (_number(tolerance) and tolerance >= 0.0):
        raise PlannerInputError("tolerance", "a number >= 0", tolerance)


@dataclass(frozen=True)
class LearningParameters:
    """The thesis's learning parameters (sections 3.4, 3.4.1 and 4.2), validated; the
    Q-learning and the rollout planner's configs extend it.

    Attributes:
        gamma: Discount factor of eq. 3.5, in [0, 1).
        iterations: Maximum number of episodes (>= 1).
        batch_rows: Grid rows per batch (>= 1).
        row_period_s: Belt travel time of one grid row [s] (the observation period).
        objective: 'v/d' (eq. 3.3), 'd=1' (value only) or 'v=1' (distance only), section 4.1.3.
        tolerance: Largest q change over an episode that counts as converged (>= 0).
    """

    gamma: float = 0.9
    iterations: int = 50
    batch_rows: int = 20
    row_period_s: float = 0.5
    objective: str = "v/d"
    tolerance: float = 1e-12

    def __post_init__(self):
        check_learning_parameters(
            self.gamma,
            self.iterations,
            self.batch_rows,
            self.row_period_s,
            self.objective,
            self.tolerance,
        )
