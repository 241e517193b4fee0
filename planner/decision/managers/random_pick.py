"""The thesis's "random picker" (the paragraphs under its table 4.6): any item the cup can meet
now, drawn uniformly, blind to value, distance and time.

Its candidates are exactly those of the proximity picker and of the thesis's Q-learning: the
items worth something that the cup can meet without waiting at the window's entry (an item
still upstream is not committed to; the picker decides again once it has entered). Only the rule
differs: a uniform draw instead of the nearest or the largest q. The draws come from a stream
seeded by `seed` (the episode runner passes the episode's seed) and `stream` (a line's robot
index, so each robot of a line draws its own sequence); `reset()` starts it again, so the same
seed gives the same picks.
"""

from __future__ import annotations

import numpy as np

from planner.decision.candidates import candidates, choice_of
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem
from planner.errors import PlannerInputError


def _check_count(field: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise PlannerInputError(field, "an integer >= 0", value)
    return value


class RandomPlanner:
    """A uniform draw among the items the cup can meet now.

    Args:
        seed: Seed of the draws (>= 0; an episode's seed).
        stream: Which of the seed's streams (>= 0; a line's robot index).
    """

    name = "random"

    def __init__(self, seed: int = 0, stream: int = 0):
        self.seed = _check_count("seed", seed)
        self.stream = _check_count("stream", stream)
        self.reset()

    def reset(self) -> None:
        """Start of an episode: the draws start again from the seed."""
        self._rng = np.random.default_rng([self.seed, self.stream])

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """One of the items the cup can meet now, each as likely (candidates in a fixed order:
        earliest exit first, then item id), or None when there is none."""
        cands = candidates(items, robot, context, immediate_only=True, with_place=False)
        if not cands:
            return None
        k = int(self._rng.integers(len(cands)))
        return choice_of(cands[k], f"random: {k + 1} of {len(cands)}")
