"""An item's material from its features, and its fusion with the stripe HMMs' prediction.

`ItemClassifier` is a scikit-learn gradient-boosted tree ensemble over `item_features`, trained
on labelled items of flows disjoint from every evaluation (`sim.evaluation.item_features`).
The stripe HMMs (the thesis's method) carry the belt's sequence: classes come in runs along a
stripe. Their prediction of an item's class from the codes of its stripe before it (the
predicted state distribution of the item's first row, before its own codes are seen) is a prior
the features cannot give; fused, the classifier's likelihood weights it:

    p(class | features, HMM) ~ p(features | class) p(class | HMM)
                             ~ [p_clf(class | features) / p_train(class)] p(class | HMM),

where p_train is the class mix the classifier was trained on (dividing by it turns the
classifier's posterior into a likelihood up to a constant). The HMMs' posterior of the item's
own cells (what the thesis's path decides from) is not used as the prior: it already holds the
item's own colour and size codes, which the features hold too, and counting them twice makes
the fusion overconfident where the codes mislead (a white pot coded as paper);
`sim.evaluation.item_features evaluate` measures both. Three modes (`CLASSIFIER_MODES`): `hmm`
(the thesis's path alone: the HMMs' posterior), `features` (the classifier alone), `fused`.

Probabilities are over (paper, plastic, aluminium), class ids 2, 3, 4.
"""

from __future__ import annotations

import functools

import numpy as np
from sklearn.ensemble import HistGradientBoostingClassifier
from threadpoolctl import ThreadpoolController

from perception.errors import PerceptionInputError
from perception.items.features import N_FEATURES
from perception.items.tree_ensemble import PackedTrees

CLASSIFIER_MODES = ("fused", "features", "hmm")
MATERIAL_IDS = (2, 3, 4)
_FLOOR = 1e-4
"""Smallest probability a source may give a class, so that one overconfident source cannot veto
the other outright."""


@functools.cache
def _thread_control() -> ThreadpoolController:
    """The process's OpenMP thread pools (looked up once: the lookup costs milliseconds)."""
    return ThreadpoolController()


class ItemClassifier:
    """Material probabilities of items from their feature vectors.

    Args:
        features: (n, N_FEATURES) training features.
        class_ids: (n,) true class ids (2 paper, 3 plastic, 4 aluminium by default).
        seed: Seed of the estimator's randomness.
        material_ids: The material class ids, in the order of the probabilities' columns
            (2, 3, ...; the thesis's three by default).
    """

    def __init__(
        self,
        features: np.ndarray,
        class_ids: np.ndarray,
        seed: int = 0,
        material_ids: tuple[int, ...] = MATERIAL_IDS,
    ):
        material_ids = tuple(int(c) for c in material_ids)
        features = np.asarray(features, dtype=np.float64)
        class_ids = np.asarray(class_ids, dtype=np.int64)
        if features.ndim != 2 or features.shape[1] != N_FEATURES:
            raise PerceptionInputError("features", f"(n, {N_FEATURES})", features.shape)
        if len(class_ids) != len(features) or not set(class_ids.tolist()) <= set(material_ids):
            raise PerceptionInputError("class_ids", f"one of {material_ids} per row", class_ids)
        counts = np.array([np.sum(class_ids == c) for c in material_ids], dtype=float)
        if np.any(counts < 5):
            raise PerceptionInputError("class_ids", "at least 5 items of each class", counts)
        self.train_prior = counts / counts.sum()
        self.estimator = HistGradientBoostingClassifier(
            max_iter=300, learning_rate=0.08, max_leaf_nodes=15, l2_regularization=1.0,
            random_state=seed,
        )  # fmt: skip
        # One thread: an OpenMP region per tree waits for a second thread, a scheduler time
        # slice each with the other core busy (the renderer, another process).
        with _thread_control().limit(limits=1, user_api="openmp"):
            self.estimator.fit(features, class_ids)
        self.material_ids = material_ids
        self._columns = [list(self.estimator.classes_).index(c) for c in material_ids]

    @functools.cached_property
    def trees(self) -> PackedTrees | None:
        """The estimator's trees as flat arrays, walked all at once (`PackedTrees`); None
        where this scikit-learn keeps its fitted trees otherwise (`probabilities` then asks the
        estimator itself)."""
        try:
            return PackedTrees(self.estimator)
        except (AttributeError, KeyError, ValueError, IndexError):
            return None

    def probabilities(self, features: np.ndarray) -> np.ndarray:
        """(n, m) p(class | features) over the m materials (paper, plastic, aluminium).

        The estimator's `predict_proba` to the bit, from `PackedTrees`: 0.3-1 ms for the few
        items of an observation against 4-6 ms tree by tree (and no OpenMP region per tree,
        whose wait for a second thread cost a scheduler time slice per tree with the other
        core busy: 3 s a call measured in an episode).
        """
        features = np.atleast_2d(np.asarray(features, dtype=np.float64))
        if features.shape[1] != N_FEATURES:
            raise PerceptionInputError("features", f"(n, {N_FEATURES})", features.shape)
        if self.trees is None:
            with _thread_control().limit(limits=1, user_api="openmp"):
                return self.estimator.predict_proba(features)[:, self._columns]
        return self.trees.probabilities(features)[:, self._columns]


def fuse(
    classifier_probs: np.ndarray, train_prior: np.ndarray, hmm_probs: np.ndarray
) -> np.ndarray:
    """(n, 3) p(class | features, HMM): the classifier's likelihood times the HMMs' prior.

    Args:
        classifier_probs: (n, 3) p_clf(class | features).
        train_prior: (3,) class mix of the classifier's training set.
        hmm_probs: (n, 3) the stripe HMMs' class distribution of each item (their prediction).
    """
    likelihood = np.maximum(np.atleast_2d(classifier_probs), _FLOOR) / np.asarray(train_prior)
    joint = likelihood * np.maximum(np.atleast_2d(hmm_probs), _FLOOR)
    return joint / joint.sum(axis=1, keepdims=True)


def combine(
    mode: str,
    hmm_probs: np.ndarray,
    classifier_probs: np.ndarray | None = None,
    train_prior: np.ndarray | None = None,
) -> np.ndarray:
    """(n, 3) class probabilities of items in classifier `mode` (one of CLASSIFIER_MODES).

    Args:
        mode: `hmm`, `features` or `fused`.
        hmm_probs: (n, 3) what the HMMs say of each item: their posterior in `hmm` mode, their
            prediction (the prior) in `fused` mode.
        classifier_probs: (n, 3) p_clf(class | features) (not needed in `hmm` mode).
        train_prior: (3,) the classifier's training class mix (not needed in `hmm` mode).
    """
    if mode not in CLASSIFIER_MODES:
        raise PerceptionInputError("classifier", " | ".join(CLASSIFIER_MODES), mode)
    hmm_probs = np.atleast_2d(np.asarray(hmm_probs, dtype=np.float64))
    if mode == "hmm":
        return hmm_probs
    if classifier_probs is None or train_prior is None:
        raise PerceptionInputError("classifier", "a trained item classifier", None)
    if mode == "features":
        return np.atleast_2d(classifier_probs)
    return fuse(classifier_probs, train_prior, hmm_probs)
