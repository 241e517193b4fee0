"""A fitted scikit-learn histogram gradient boosting classifier's trees, walked all at once.

`HistGradientBoostingClassifier.predict_proba` walks its trees one after the other (900 for
300 rounds of 3 classes), each through a Python call: about 10 ms for the few items of an
observation, whatever their number. `PackedTrees` copies the same trees into flat arrays and
walks every tree for every item together, one tree level per numpy step. Each class's raw score
is its baseline plus the trees' leaf values added in scikit-learn's order, so the scores, and
the probabilities from them (through the estimator's own loss), are the same to the bit
(`tests/test_item_features.py` holds the two side by side).

It reads the estimator's fitted trees, baseline and loss (`_predictors`, `_baseline_prediction`,
`_loss`), which scikit-learn does not publish: a version that changes them fails that test.
"""

from __future__ import annotations

import numpy as np
from sklearn.ensemble import HistGradientBoostingClassifier

from perception.errors import PerceptionInputError


class PackedTrees:
    """The trees of a fitted `HistGradientBoostingClassifier` on numerical features.

    Args:
        estimator: The fitted classifier (no categorical features).
    """

    def __init__(self, estimator: HistGradientBoostingClassifier):
        rounds = estimator._predictors
        self.n_classes = len(rounds[0])
        trees = [tree.nodes for round_trees in rounds for tree in round_trees]
        if any(np.any(nodes["is_categorical"]) for nodes in trees):
            raise PerceptionInputError("estimator", "trees on numerical features only", "a split")
        # Node ids made global: tree t's node n is node offsets[t] + n of the flat arrays.
        sizes = np.array([len(nodes) for nodes in trees])
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        nodes = np.concatenate(trees)
        shift = np.repeat(offsets, sizes)
        self.roots = offsets
        self.feature = nodes["feature_idx"].astype(np.int64)
        self.threshold = nodes["num_threshold"].astype(np.float64)
        self.missing_left = nodes["missing_go_to_left"].astype(bool)
        self.left = nodes["left"].astype(np.int64) + shift
        self.right = nodes["right"].astype(np.int64) + shift
        self.is_leaf = nodes["is_leaf"].astype(bool)
        self.value = nodes["value"].astype(np.float64)
        self.depth = int(nodes["depth"].max())
        self.baseline = np.asarray(estimator._baseline_prediction, dtype=np.float64).reshape(-1)
        self.loss = estimator._loss

    def raw_scores(self, features: np.ndarray) -> np.ndarray:
        """(n, n_classes) each class's baseline plus its trees' leaf values, summed round by
        round (scikit-learn's order)."""
        features = np.asarray(features, dtype=np.float64)
        n = len(features)
        node = np.broadcast_to(self.roots, (n, len(self.roots)))
        rows = np.arange(n)[:, None]
        for _ in range(self.depth):
            x = features[rows, self.feature[node]]
            missing = np.isnan(x)
            left = np.where(missing, self.missing_left[node], x <= self.threshold[node])
            step = np.where(left, self.left[node], self.right[node])
            node = np.where(self.is_leaf[node], node, step)
        leaf_values = self.value[node].reshape(n, -1, self.n_classes)  # (n, rounds, classes)
        terms = np.concatenate(
            [np.broadcast_to(self.baseline, (n, 1, self.n_classes)), leaf_values], axis=1
        )
        return np.add.accumulate(terms, axis=1)[:, -1, :]

    def probabilities(self, features: np.ndarray) -> np.ndarray:
        """(n, n_classes) the class probabilities, in the estimator's class order."""
        return self.loss.predict_proba(np.asfortranarray(self.raw_scores(features)))
