"""Item features from pixels, the item classifier and its fusion with the stripe HMMs."""

import math

import numpy as np
import pytest

from perception.errors import PerceptionInputError
from perception.items.classifier import ItemClassifier, combine, fuse
from perception.items.features import FEATURE_NAMES, N_FEATURES, item_features
from sim.sensing.item_classifier import load_table, trained_item_classifier

PIXEL = 0.002


def _rect(length, width, height, rgb, noise=0.0, seed=0):
    b, y = np.meshgrid(np.arange(0, length, PIXEL), np.arange(0, width, PIXEL), indexing="ij")
    rng = np.random.default_rng(seed)
    h = height + noise * rng.standard_normal(b.size)
    return b.ravel(), y.ravel(), h, np.tile(np.asarray(rgb, np.uint8), (b.size, 1))


def _disc(radius, height, rgb):
    b, y = np.meshgrid(np.arange(-radius, radius, PIXEL), np.arange(-radius, radius, PIXEL))
    inside = b**2 + y**2 <= radius**2
    n = int(inside.sum())
    return b[inside], y[inside], np.full(n, height), np.tile(np.asarray(rgb, np.uint8), (n, 1))


def feature(vector, name):
    return vector[FEATURE_NAMES.index(name)]


def test_a_sheet_is_long_wide_full_and_flat_through_depth_noise():
    f = item_features(*_rect(0.21, 0.148, 0.001, (235, 235, 230), noise=0.004))
    assert len(f) == N_FEATURES
    assert feature(f, "length_m") == pytest.approx(0.21, abs=0.004)
    assert feature(f, "width_m") == pytest.approx(0.148, abs=0.004)
    assert feature(f, "fill") == pytest.approx(1.0, abs=0.05)
    assert feature(f, "area_m2") == pytest.approx(0.21 * 0.148, rel=0.03)
    assert feature(f, "height_p50_m") == pytest.approx(0.001, abs=0.001)
    assert feature(f, "above_3cm") == 0.0
    assert feature(f, "bright_grey") == 1.0


def test_a_standing_can_is_round_tall_and_red():
    f = item_features(*_disc(0.033, 0.115, (200, 20, 20)))
    assert feature(f, "fill") == pytest.approx(math.pi / 4, abs=0.05)
    assert feature(f, "height_p90_m") == pytest.approx(0.115, abs=1e-6)
    assert feature(f, "above_6cm") == 1.0
    assert feature(f, "hue_0") == 1.0 and feature(f, "coloured") == 1.0


def _lying(kind, length, radius, yaw, rgb=(30, 80, 200), noise=0.0):
    """A lying can ("cylinder": flat ends) or bottle ("capsule": half-sphere ends) seen from
    above, its axis at `yaw` [rad]: its pixels and heights above the belt [m]."""
    grid = np.arange(-0.13, 0.13, PIXEL)
    b, y = (a.ravel() for a in np.meshgrid(grid, grid, indexing="ij"))
    along = b * math.cos(yaw) + y * math.sin(yaw)
    across = -b * math.sin(yaw) + y * math.cos(yaw)
    if kind == "cylinder":
        off_axis = np.where(np.abs(along) <= length / 2, np.abs(across), np.inf)
    else:
        off_axis = np.hypot(np.clip(np.abs(along) - (length / 2 - radius), 0, None), across)
    inside = off_axis <= radius
    h = radius + np.sqrt(np.clip(radius**2 - off_axis[inside] ** 2, 0, None))
    h = h + noise * np.random.default_rng(0).standard_normal(h.size)
    rgb = np.tile(np.asarray(rgb, np.uint8), (int(inside.sum()), 1))
    return b[inside], y[inside], h, rgb, along[inside]


@pytest.mark.parametrize("yaw", [0.0, 0.5, 1.3, 2.6])
def test_a_bottles_round_ends_are_narrower_and_lower_than_a_cans_flat_ends(yaw):
    """A 0.5 L can (66 x 168 mm) and a 0.5 L bottle (65 x 205 mm) lying, the same colour:
    the can's ends are as wide and nearly as high as its middle, the bottle's half-spheres are
    not, at any yaw, through stereo depth noise, and with one of the bottle's ends hidden."""
    can = item_features(*_lying("cylinder", 0.168, 0.033, yaw, noise=0.004)[:4])
    *bottle_pixels, along = _lying("capsule", 0.205, 0.0325, yaw, noise=0.004)
    bottle = item_features(*bottle_pixels)
    assert feature(can, "end_width") == pytest.approx(1.0, abs=0.06)
    assert feature(can, "end_height") == pytest.approx(0.95, abs=0.08)
    assert feature(bottle, "end_width") == pytest.approx(0.63, abs=0.08)
    assert feature(bottle, "end_height") == pytest.approx(0.73, abs=0.08)
    hidden = along <= 0.06  # a neighbour covers the bottle's far end: cut square there
    half_hidden = item_features(*(a[hidden] for a in bottle_pixels))
    rounder_end = feature(bottle, "end_width")
    assert feature(half_hidden, "end_width") == pytest.approx(rounder_end, abs=0.08)


def test_features_refuse_mismatched_pixels():
    b, y, h, rgb = _rect(0.05, 0.05, 0.0, (0, 0, 200))
    with pytest.raises(PerceptionInputError):
        item_features(b, y[:-1], h, rgb)


def test_classifier_learns_separable_items_and_reports_its_training_mix():
    rng = np.random.default_rng(0)
    rows, labels = [], []
    for cls, (length, height, rgb) in {
        2: (0.2, 0.001, (235, 235, 230)),
        3: (0.2, 0.035, (190, 215, 225)),
        4: (0.12, 0.033, (200, 20, 20)),
    }.items():
        for k in range(30 if cls != 4 else 15):
            scale = 1 + 0.15 * (rng.random() - 0.5)
            rows.append(item_features(*_rect(length * scale, 0.07, height, rgb, 0.004, k)))
            labels.append(cls)
    clf = ItemClassifier(np.array(rows), np.array(labels))
    assert clf.train_prior == pytest.approx([30 / 75, 30 / 75, 15 / 75])
    test = item_features(*_rect(0.12, 0.07, 0.033, (200, 20, 20), 0.004, 99))
    assert np.argmax(clf.probabilities(test)[0]) == 2


def test_fusion_is_likelihood_times_hmm_posterior():
    prior = np.array([0.3, 0.4, 0.3])
    hmm = np.array([[0.2, 0.5, 0.3]])
    # A classifier that learnt nothing returns its training mix: the HMM decides alone.
    assert fuse(prior[None], prior, hmm) == pytest.approx(hmm)
    clf = np.array([[0.6, 0.3, 0.1]])
    expected = clf / prior * hmm
    assert fuse(clf, prior, hmm) == pytest.approx(expected / expected.sum())
    assert combine("hmm", hmm) == pytest.approx(hmm)
    assert combine("features", hmm, clf, prior) == pytest.approx(clf)
    with pytest.raises(PerceptionInputError, match="classifier"):
        combine("fused", hmm)
    with pytest.raises(PerceptionInputError, match="classifier"):
        combine("colour", hmm, clf, prior)


def _estimators_probabilities(clf: ItemClassifier, features: np.ndarray) -> np.ndarray:
    columns = [list(clf.estimator.classes_).index(c) for c in clf.material_ids]
    return clf.estimator.predict_proba(features)[:, columns]


def test_classifier_gives_the_estimators_probabilities_to_the_bit():
    """`probabilities` walks the packed trees; the numbers are scikit-learn's own, missing
    feature values included."""
    rng = np.random.default_rng(1)
    features = rng.normal(size=(90, N_FEATURES))
    labels = np.repeat([2, 3, 4], 30)
    features[:, 0] += labels  # something to learn
    features[::7, 3] = np.nan  # the trees learn where missing values go
    clf = ItemClassifier(features, labels)
    assert clf.trees is not None, "this scikit-learn's trees are walked packed"
    test = rng.normal(size=(7, N_FEATURES)) + np.array([2, 3, 4, 2, 3, 4, 3])[:, None]
    test[1, 3] = test[4, 0] = np.nan
    np.testing.assert_array_equal(clf.probabilities(test), _estimators_probabilities(clf, test))
    np.testing.assert_array_equal(
        clf.probabilities(test[2]), _estimators_probabilities(clf, test[2:3])
    )


def test_the_cameras_classifier_gives_the_estimators_probabilities_to_the_bit():
    """The episode's classifier (300 rounds of 3 trees) on every item of its training table."""
    clf = trained_item_classifier()
    features = load_table()["features"]
    np.testing.assert_array_equal(
        clf.probabilities(features), _estimators_probabilities(clf, features)
    )


def test_a_catalogues_recorded_table_is_named_after_the_camera_code(monkeypatch):
    """A custom catalogue's training table is recorded through the camera perception: its name
    holds the camera path's code, so new code records it afresh (here: one folder less read)."""
    from sim.flow.catalogue import load_catalogue
    from sim.sensing import item_classifier

    catalogue = load_catalogue()
    path = item_classifier.catalogue_table(catalogue)
    assert item_classifier.catalogue_table(catalogue) == path
    monkeypatch.setattr(item_classifier, "_RECORDING_CODE", ("perception/camera",))
    assert item_classifier.catalogue_table(catalogue) == path  # read once a process
    item_classifier.recording_code_digest.cache_clear()
    assert item_classifier.catalogue_table(catalogue) != path
    monkeypatch.undo()
    item_classifier.recording_code_digest.cache_clear()
    assert item_classifier.catalogue_table(catalogue) == path


def test_the_evaluations_table_names_the_item_types_the_classifier_errs_on():
    """`python -m sim.evaluation.item_features evaluate` names the types taken for another
    material: here crushed PET bottles that look exactly like the red crushed cans."""
    from sim.evaluation.item_features import accuracy_table
    from sim.flow.catalogue import load_catalogue

    names = [t.name for t in load_catalogue().types]
    kinds = {  # type: (class, length, height, colour)
        "paper_sheet_a4": (2, 0.2, 0.001, (235, 235, 230)),
        "pet_bottle_0l5": (3, 0.2, 0.035, (190, 215, 225)),
        "can_500_lying_crushed": (4, 0.17, 0.022, (200, 20, 20)),
    }
    rows, labels, types = [], [], []
    for name, (cls, length, height, rgb) in kinds.items():
        for k in range(20):
            rows.append(item_features(*_rect(length, 0.08, height, rgb, 0.004, k)))
            labels.append(cls)
            types.append(names.index(name))
    clf = ItemClassifier(np.array(rows), np.array(labels))
    lookalikes = [
        item_features(*_rect(0.17, 0.08, 0.022, (200, 20, 20), 0.004, 50 + k)) for k in range(3)
    ]
    table = {
        "features": np.array(rows[:5] + rows[40:42] + lookalikes),
        "class_id": np.array(labels[:5] + labels[40:42] + [3, 3, 3]),
        "type_index": np.array(
            types[:5] + types[40:42] + [names.index("pet_bottle_0l5_crushed")] * 3
        ),
        "hmm": np.full((10, 3), 1 / 3),
        "hmm_prior": np.full((10, 3), 1 / 3),
    }
    errors = [line for line in accuracy_table(table, clf) if line.startswith("fused mode's errors")]
    assert errors == [
        "fused mode's errors (3 of 10), by item type: pet_bottle_0l5_crushed 3 of 3 (aluminium 3)"
    ]


_WAITER = """
import sys
from pathlib import Path
from sim.sensing.item_recording import write_once
print("ready", flush=True)
wrote = write_once(Path(sys.argv[1]), lambda p: p.write_text("waiter"))
print(wrote, flush=True)
"""


def test_a_catalogues_table_is_recorded_by_one_process_the_others_wait_and_read_it(tmp_path):
    """A sweep's workers that build camera perceptions on the same new catalogue at once: the
    first records the table while holding its lock; another waits for the lock, then finds the
    table and records nothing (`sim.sensing.item_recording.write_once`)."""
    import subprocess
    import sys
    import time

    from sim.sensing.item_recording import exclusive, write_once

    table = tmp_path / "item_features-abc.npz"
    with exclusive(table):  # this process is the first: recording
        waiter = subprocess.Popen(
            [sys.executable, "-c", _WAITER, str(table)], stdout=subprocess.PIPE, text=True
        )
        assert waiter.stdout is not None
        assert waiter.stdout.readline().strip() == "ready"
        time.sleep(0.5)
        assert waiter.poll() is None  # waiting for the lock
        table.write_text("first")
    out, _ = waiter.communicate(timeout=60)
    assert waiter.returncode == 0 and out.strip() == "False"
    assert table.read_text() == "first"
    assert write_once(table, lambda p: p.write_text("again")) is False
    fresh = tmp_path / "item_features-def.npz"
    assert write_once(fresh, lambda p: p.write_text("made")) is True
    assert fresh.read_text() == "made"
