"""The camera's item classifier: fitted from the shipped training table, cached.

`sim/data/item_features.npz` holds the labelled items of the training flows (features, true
class, type, seed, belt speed), written by `python -m sim.experiments.item_features record
--train`; its seeds are disjoint from every evaluation's. The classifier
(`perception.items.classifier.ItemClassifier`) is fitted from it once and kept in
`runs/cache` under a name made of the table's and the fitting code's digest and the
scikit-learn version, so a new table, new code or another scikit-learn fits afresh.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pickle

import numpy as np
import sklearn

from perception.items.classifier import ItemClassifier
from sim.errors import InvalidInput
from sim.paths import DATA_DIR, REPO_ROOT

TRAINING_TABLE = DATA_DIR / "item_features.npz"
CACHE_DIR = REPO_ROOT / "runs" / "cache"
_CODE = ("perception/items/classifier.py", "perception/items/features.py")
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


def _cache_path(path) -> object:
    digest = hashlib.sha1(path.read_bytes())
    for rel in _CODE:
        digest.update((REPO_ROOT / rel).read_bytes())
    digest.update(sklearn.__version__.encode())
    return CACHE_DIR / f"item_classifier-{digest.hexdigest()[:12]}.pkl"


@functools.lru_cache(maxsize=2)
def trained_item_classifier(path=TRAINING_TABLE) -> ItemClassifier:
    """The item classifier fitted on the training table (from the cache when there)."""
    if not path.exists():
        allowed = "the item classifier's training table (python -m sim.experiments.item_features)"
        raise InvalidInput("item table", allowed, "missing", str(path))
    cache = _cache_path(path)
    if cache.exists():
        with open(cache, "rb") as f:
            return pickle.load(f)
    table = load_table(path)
    classifier = ItemClassifier(table["features"], table["class_id"], seed=FIT_SEED)
    cache.parent.mkdir(parents=True, exist_ok=True)
    tmp = cache.with_name(f".{cache.stem}.{os.getpid()}.pkl")
    with open(tmp, "wb") as f:
        pickle.dump(classifier, f)
    os.replace(tmp, cache)
    return classifier
