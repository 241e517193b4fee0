"""The confidence rule: an item whose class is too uncertain is left on the belt.

A plant would rather let an item ride on to the residue line than risk contaminating a bin:
a tracked item whose most probable material (paper, plastic or aluminium) has a posterior
probability below `min_class_confidence` (`sim.episode.config`) is not offered to the decision
manager. The episode applies the rule in one place, where it builds the tracked items every
decision manager chooses among (`sim.episode.stations.offerable_items`), so every planner
(and any agent stepping the episode) sees the same filtered items. At the default threshold 0
nothing is held back. Tracks held back until they leave the tracker are counted in
`left_unsure` (`sim.results.metrics`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from planner.decision.interface import TrackedItem


def top_class_probability(class_probs: Sequence[float]) -> float:
    """Posterior probability of the most probable material of (void, paper, plastic,
    aluminium) probabilities: the probability of the class the item would be sorted as."""
    return float(max(class_probs[1:]))


def is_unsure(class_probs: Sequence[float], min_confidence: float) -> bool:
    """True when the most probable material is less probable than `min_confidence` (in [0, 1];
    a probability equal to it is sure enough)."""
    return top_class_probability(class_probs) < min_confidence


def sure_items(items: Iterable[TrackedItem], min_confidence: float) -> list[TrackedItem]:
    """The items sure enough to be offered to a decision manager, in their order (all of them
    at a `min_confidence` <= 0: a `TrackedItem`'s probabilities are >= 0)."""
    if min_confidence <= 0.0:
        return list(items)
    return [item for item in items if not is_unsure(item.class_probs, min_confidence)]
