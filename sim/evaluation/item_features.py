"""The item classifier's shipped training table and its item-level scores.

Flows are recorded past the episode's own camera perception and their reports labelled with
the true items (`sim.sensing.item_recording`: features, the HMMs' posterior, true class and
type per item).

    python -m sim.evaluation.item_features record --out sim/data/item_features.npz
    python -m sim.evaluation.item_features evaluate --seeds 0 1 2 3 4

`record` writes the training table the shipped classifier is fitted from (training seeds
100-115 at x1, x1.2, x1.5, flows of 100 and of 200 items in 90 s: `TRAIN_SEEDS`,
`SPEED_FACTORS`, `TRAIN_ITEMS`); `evaluate` records held-out flows and prints, per class and
overall, the accuracy of the `hmm`, `features` and `fused` modes. Recordings are cached per
flow in `--cache` (default `item_features/<digest of the camera and perception code>` in the
user's cache folder, `sim.user_cache`, so a change of that code records afresh), named after
the flow's settings.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from perception.codes import CLASS_NAMES
from perception.items.classifier import MATERIAL_IDS, ItemClassifier, fuse
from sim.flow.catalogue import load_catalogue
from sim.sensing.item_classifier import FIT_SEED, TRAINING_TABLE, load_table, recording_code_digest
from sim.sensing.item_recording import MATCH_M, gather, save_arrays
from sim.user_cache import cache_dir

CACHE_FOLDER = "item_features"
"""`--cache`'s default is this folder of the user's cache folder, then one named by
`recording_code_digest()` (read when the command runs)."""
TRAIN_SEEDS = tuple(range(100, 116))
SPEED_FACTORS = (1.0, 1.2, 1.5)
TRAIN_ITEMS = (100, 200)
"""Items of a 90 s training flow: the headline's 6 per metre and the 12 of tables 4.5/4.6 (busy
belts: items touching, their footprints cut apart)."""


def accuracy_table(table: dict, classifier: ItemClassifier) -> list[str]:
    """Lines of the item-level table: accuracy per class of each mode on labelled items."""
    labelled = table["class_id"] > 0
    truth = table["class_id"][labelled]
    hmm = table["hmm"][labelled]
    clf = classifier.probabilities(table["features"][labelled])
    names = [CLASS_NAMES[c - 1] for c in MATERIAL_IDS]
    lines = [
        "| mode | " + " | ".join(names) + " | all |",
        "|---|" + "---|" * (len(names) + 1),
    ]
    prior = table["hmm_prior"][labelled]
    rows = (
        ("hmm (the thesis's: the HMMs' posterior)", hmm),
        ("features", clf),
        ("fused (features x the HMMs' prediction)", fuse(clf, classifier.train_prior, prior)),
        ("features x the HMMs' posterior", fuse(clf, classifier.train_prior, hmm)),
        ("the HMMs' prediction alone", prior),
    )
    for label, probs in rows:
        guess = np.asarray(MATERIAL_IDS)[np.argmax(probs, axis=1)]
        cells = []
        for c in MATERIAL_IDS:
            mine = truth == c
            cells.append(f"{np.mean(guess[mine] == c):.3f} (n={int(mine.sum())})")
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {np.mean(guess == truth):.3f} |")
    lines.append(errors_by_type(table, labelled, fuse(clf, classifier.train_prior, prior)))
    unmatched = int(np.sum(~labelled))
    lines.append(f"reports matched to no true item within {MATCH_M * 1000:.0f} mm: {unmatched}")
    return lines


def errors_by_type(
    table: dict, labelled: np.ndarray, probs: np.ndarray, most: int = 6, mode: str = "fused mode's"
) -> str:
    """One line: the item types `probs` (of the `labelled` items) err on most (wrong of all, and
    as what), named by the default catalogue (`table["type_index"]` indexes its types)."""
    names = [t.name for t in load_catalogue().types]
    types = table["type_index"][labelled]
    guess = np.asarray(MATERIAL_IDS)[np.argmax(probs, axis=1)]
    wrong = guess != table["class_id"][labelled]
    counts = [(int(np.sum(wrong & (types == k))), k) for k in np.unique(types)]
    counts.sort(reverse=True)
    parts = []
    for n_wrong, k in counts[:most]:
        if n_wrong == 0:
            break
        as_what = np.bincount(guess[wrong & (types == k)], minlength=max(MATERIAL_IDS) + 1)
        taken = ", ".join(f"{CLASS_NAMES[c - 1]} {as_what[c]}" for c in MATERIAL_IDS if as_what[c])
        parts.append(f"{names[k]} {n_wrong} of {int(np.sum(types == k))} ({taken})")
    total = f"{int(wrong.sum())} of {int(labelled.sum())}"
    return f"{mode} errors ({total}), by item type: " + ("; ".join(parts) or "none")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim.evaluation.item_features")
    parser.add_argument("action", choices=("record", "evaluate"))
    parser.add_argument("--seeds", type=int, nargs="+", default=None)
    parser.add_argument("--speed-factors", type=float, nargs="+", default=list(SPEED_FACTORS))
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=TRAINING_TABLE)
    parser.add_argument("--table", type=Path, default=TRAINING_TABLE, help="training table")
    parser.add_argument(
        "--items", type=int, nargs="+", default=None, help="items of a 90 s flow (each count)"
    )
    args = parser.parse_args(argv)
    args.cache = args.cache or cache_dir() / CACHE_FOLDER / recording_code_digest()
    items = tuple(args.items or ((100,) if args.action == "evaluate" else TRAIN_ITEMS))
    if args.action == "record":
        seeds = args.seeds or list(TRAIN_SEEDS)
        table = gather(args.cache, seeds, args.speed_factors, items=items)
        keep = table["class_id"] > 0
        out = {k: v[keep] for k, v in table.items()}
        save_arrays(args.out, out)
        counts = {CLASS_NAMES[c - 1]: int(np.sum(out["class_id"] == c)) for c in MATERIAL_IDS}
        print(f"wrote {args.out}: {int(keep.sum())} labelled items {counts}", file=sys.stderr)
        return 0
    seeds = args.seeds or [0, 1, 2, 3, 4]
    train = load_table(args.table)
    overlap = set(np.unique(train["seed"]).tolist()) & set(seeds)
    if overlap:
        print(f"seeds: held-out seeds only (these trained the classifier: {sorted(overlap)})")
        return 2
    classifier = ItemClassifier(train["features"], train["class_id"], seed=FIT_SEED)
    table = gather(args.cache, seeds, args.speed_factors, items=items)
    trained = sorted(np.unique(train["seed"]).tolist())
    n_train = len(train["class_id"])
    print(
        f"held-out seeds {seeds} at x{args.speed_factors}, {list(items)} items in 90 s; trained "
        f"on seeds {trained} ({n_train})"
    )
    print("\n".join(accuracy_table(table, classifier)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
