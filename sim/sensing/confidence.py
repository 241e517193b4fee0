"""The confidence rule: an item whose class is too uncertain is left on the belt.

A plant would rather let an item ride on to the residue line than risk contaminating a bin:
a tracked item whose most probable material (paper, plastic or aluminium) has a posterior
probability below `min_class_confidence` (`sim.config`) is not offered to the decision
manager. The episode applies the rule in one place, where it builds the tracked items every
decision manager chooses among (`sim.episode.stations.Offers.items`), so every planner
(and any agent stepping the episode) sees the same filtered items. At a threshold of 0 nothing
is held back. Tracks held back until they leave the tracker are counted in `left_unsure`
(`sim.results.metrics`).

The threshold a config leaves unset is its classifier's own
(`sim.config.settings.default_min_confidence`): 0.9 for
the item classifier's modes (`fused`, `features`), chosen from the classifier's cross-validation
on its own training table (`python -m sim.evaluation.item_classifier_cv`: at 0.9 it leaves 0.6 %
of the right items and offers under half of the wrong ones), and 0 for the stripe HMMs alone
(`hmm`, the thesis's path, which has no such rule and whose posteriors are rarely that sure) and
for truth perception (its classes are certain).
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
