"""The camera's item classifier: fitted from the shipped training table, cached.

`sim/data/item_features.npz` holds the labelled items of the training flows (features, true
class, type, seed, belt speed), written by `python -m sim.evaluation.item_features record
--train`; its seeds are disjoint from every evaluation's. The classifier
(`perception.items.classifier.ItemClassifier`) is fitted from it once and kept in the user's
cache folder (`sim.user_cache`) under a name made of the table's and the fitting code's digest
and the scikit-learn version, so a new table, new code or another scikit-learn fits afresh.

The kept classifier is a pickle: the fitted scikit-learn estimator whole, which the
classifier's fallback path and the evaluations use, read back to the bit (a form of plain
arrays would hold only the packed trees, and rebuild the estimator's loss from scikit-learn's
private classes). Loading a pickle runs the code it names, so it is written readable and
writable by its user only (mode 0o600) and read only when it is a regular file of this user's
that no one else can write (`sim.user_cache.open_own_file`); anything else is refused in one
line, and deleting the file fits the classifier afresh (about 4 s).
"""

from __future__ import annotations

import functools
import hashlib
import os
import pickle
from pathlib import Path

import numpy as np
import sklearn

from perception.items.classifier import ItemClassifier
from sim.errors import InvalidInput
from sim.paths import DATA_DIR, REPO_ROOT, temporary_path
from sim.user_cache import cache_dir, open_own_file

TRAINING_TABLE = DATA_DIR / "item_features.npz"
_CODE = (
    "perception/items/classifier.py",
    "perception/items/features.py",
    "perception/items/tree_ensemble.py",
)
FIT_SEED = 0


def load_table(path=TRAINING_TABLE) -> dict[str, np.ndarray]:
    """The arrays of a labelled item table (refused in one line when missing or broken)."""
    try:
        with np.load(path) as table:
            out = {key: table[key] for key in table.files}
    except (OSError, ValueError) as exc:
        raise InvalidInput(
            "item table", "a readable labelled item table (.npz)", str(exc), str(path)
        ) from None
    if "features" not in out or "class_id" not in out:
        raise InvalidInput("item table", "arrays 'features' and 'class_id'", sorted(out), str(path))
    return out


def _cache_path(path: Path) -> Path:
    digest = hashlib.sha1(path.read_bytes())
    for rel in _CODE:
        digest.update((REPO_ROOT / rel).read_bytes())
    digest.update(sklearn.__version__.encode())
    return cache_dir() / f"item_classifier-{digest.hexdigest()[:12]}.pkl"


_RECORDING_CODE = ("perception/camera", "perception/items", "sim/cell", "sim/sensing")
"""The code a recorded training table depends on (the camera, its perception, the item pool):
a catalogue's table is named after it too, so a change records it afresh instead of fitting
the classifier on what an earlier camera saw."""
CUSTOM_TRAIN_SEEDS = tuple(range(100, 106))
CUSTOM_SPEED_FACTORS = (1.0, 1.5)
"""The training flows recorded for a catalogue other than the default (12 flows of 100 items;
the shipped table of the default catalogue has 96): seeds disjoint from every evaluation's."""


def is_default_catalogue(catalogue) -> bool:
    """The shipped catalogue (`sim/data/items.toml`), whose training table is shipped too."""
    from sim.flow.catalogue import load_catalogue

    return catalogue is None or catalogue.digest == load_catalogue().digest


def catalogue_table(catalogue, mix: dict | None = None) -> Path:
    """Where the training table of `catalogue` (and its class `mix`) is kept (the user's cache
    folder, named by content): recorded once through the camera perception by
    `sim.sensing.item_recording.ensure_catalogue_table` when the first camera episode on it is
    built."""
    key = hashlib.sha1(catalogue.digest.encode())
    key.update(repr(sorted((mix or {}).items())).encode())
    key.update(recording_code_digest().encode())
    return cache_dir() / f"item_features-{key.hexdigest()[:12]}.npz"


@functools.cache
def recording_code_digest() -> str:
    """Digest (12 hex digits) of the code a recorded item table depends on (`_RECORDING_CODE`):
    recordings kept under it are never read back by another camera or feature code. Read once a
    process, so that a run that records a table finds it again under the same name even when
    the files change meanwhile."""
    key = hashlib.sha1()
    for folder in _RECORDING_CODE:
        for path in sorted((REPO_ROOT / folder).glob("*.py")):
            key.update(path.read_bytes())
    return key.hexdigest()[:12]


def trained_item_classifier(catalogue=None, mix: dict | None = None) -> ItemClassifier:
    """The item classifier of `catalogue` (the default one when None): fitted on the shipped
    training table for the default catalogue, on a table recorded for any other
    (`catalogue_table`); from the cache when there."""
    if is_default_catalogue(catalogue):
        return _fitted(TRAINING_TABLE, (2, 3, 4))
    path = catalogue_table(catalogue, mix)
    if not path.exists():
        allowed = (
            "the item classifier's training table of this catalogue, recorded when a camera "
            "episode on it is built (sim.sensing.item_recording.ensure_catalogue_table)"
        )
        raise InvalidInput("item table", allowed, "missing", str(path))
    return _fitted(path, catalogue.materials.ids)


@functools.lru_cache(maxsize=4)
def _fitted(path, material_ids: tuple[int, ...]) -> ItemClassifier:
    """The item classifier fitted on the table at `path` (from the cache when there)."""
    if not path.exists():
        allowed = "the item classifier's training table (python -m sim.evaluation.item_features)"
        raise InvalidInput("item table", allowed, "missing", str(path))
    cache = _cache_path(path)
    if cache.exists():
        with open_own_file(cache, "item classifier cache") as f:
            return pickle.load(f)
    table = load_table(path)
    classifier = ItemClassifier(
        table["features"], table["class_id"], seed=FIT_SEED, material_ids=material_ids
    )
    _keep(cache, classifier)
    return classifier


def _keep(cache: Path, classifier: ItemClassifier) -> None:
    """Write `classifier` to `cache` (mode 0o600) through a temporary renamed over it."""
    tmp = temporary_path(cache)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o600)
        with os.fdopen(fd, "wb") as f:
            pickle.dump(classifier, f)
        os.replace(tmp, cache)
    finally:
        tmp.unlink(missing_ok=True)
