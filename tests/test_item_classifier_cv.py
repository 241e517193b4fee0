"""The item classifier cross-validated by training seed, and the confidence rule's curve."""

import numpy as np

from perception.items.features import N_FEATURES
from sim.evaluation.item_classifier_cv import out_of_fold_probabilities, rule_curve


def test_the_rules_curve_counts_wrong_items_offered_and_right_ones_left():
    probs = np.array([[0.95, 0.03, 0.02], [0.6, 0.3, 0.1], [0.1, 0.85, 0.05], [0.2, 0.2, 0.6]])
    truth = np.array([2, 3, 3, 4])  # the second item is wrong (taken for paper at 0.6)
    assert rule_curve(probs, truth, [0.5, 0.7, 0.9]) == [
        (0.5, 1, 0, 0.0),
        (0.7, 0, 1, 0.25),  # the aluminium item at 0.6 is left too
        (0.9, 0, 2, 0.5),
    ]


def test_each_seeds_items_are_classed_by_a_classifier_fitted_on_the_other_seeds():
    """A seed whose items carry their class's mark in a feature no other seed uses is classed
    by chance out of the fold (a fit that saw it would class it by the mark); the other seeds,
    separable by their first feature, are classed right."""
    rng = np.random.default_rng(0)
    seeds = np.repeat(np.arange(8), 60)
    class_ids = np.tile(np.repeat([2, 3, 4], 20), 8)
    features = rng.normal(size=(len(seeds), N_FEATURES))
    odd = seeds >= 6  # the last fold: no first-feature mark, its class in feature 1 instead
    features[~odd, 0] += class_ids[~odd] * 10.0
    features[odd, 1] += class_ids[odd] * 10.0
    probs = out_of_fold_probabilities({"features": features, "class_id": class_ids, "seed": seeds})
    assert probs.shape == (480, 3)
    assert np.allclose(probs.sum(axis=1), 1.0)
    right = np.argmax(probs, axis=1) + 2 == class_ids
    assert right[~odd].mean() > 0.95
    assert right[odd].mean() < 0.6
