"""The camera's items in the varied world: found one by one and classed by the fused classifier.

A short flow of a seed no training or tuning used rides the belt in physics past the episode's
camera perception (rendered frame, noisy stereo depth, stripe HMMs, segmentation, item
features, the shipped classifier fused with the HMMs).
"""

import numpy as np
import pytest

from sim.sensing.item_recording import record

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def items():
    return record(1.0, seed=7, n_items=30, duration_s=27.0)


def test_every_report_is_one_true_item(items):
    # Reports lie on a true item (within 3 cm of its centre; on held-out flows 97 % do, the
    # rest are merged or cut pieces); about one report per item.
    assert np.mean(items["class_id"] > 0) >= 0.9
    assert 26 <= len(items["class_id"]) <= 34


def test_fused_classes_beat_the_hmms_alone(items):
    from perception.items.classifier import combine
    from sim.sensing.item_classifier import trained_item_classifier

    clf = trained_item_classifier()
    known = items["class_id"] > 0
    truth = items["class_id"][known]
    probs = clf.probabilities(items["features"][known])
    fused = combine("fused", items["hmm_prior"][known], probs, clf.train_prior)
    fused_ok = np.mean(np.argmax(fused, axis=1) + 2 == truth)
    hmm_ok = np.mean(np.argmax(items["hmm"][known], axis=1) + 2 == truth)
    assert fused_ok >= 0.9
    assert fused_ok > hmm_ok
