"""The item classifier cross-validated on its own training table, and the confidence rule's price.

The shipped table (`sim/data/item_features.npz`) holds the labelled items of 16 training seeds.
Its seeds are split into folds of `SEEDS_PER_FOLD` consecutive seeds; each fold is classed by a
classifier fitted on the others (items of one flow never on both sides), so every item gets a
class probability from a classifier that never saw its flow. From these:

- the error rate, and the item types most often taken for another material;
- for each threshold of the confidence rule (`min_class_confidence`,
  `sim.sensing.confidence`), the wrong items it would still let through and the share of right
  ones it would leave on the belt, the curve a threshold is chosen from without touching any
  evaluation seed.

    python -m sim.evaluation.item_classifier_cv [--table PATH] [--thresholds 0.5 0.8 0.9 ...]

It fits 8 classifiers (about 20 s of CPU on the shipped table).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from perception.items.classifier import MATERIAL_IDS, ItemClassifier
from sim.evaluation.item_features import errors_by_type
from sim.sensing.item_classifier import FIT_SEED, TRAINING_TABLE, load_table

SEEDS_PER_FOLD = 2
THRESHOLDS = (0.5, 0.8, 0.9, 0.95, 0.98)


def out_of_fold_probabilities(table: dict, seeds_per_fold: int = SEEDS_PER_FOLD) -> np.ndarray:
    """(n, 3) class probabilities of every item of `table` from a classifier fitted on the
    items of the other folds' seeds (folds of `seeds_per_fold` consecutive seeds)."""
    seeds = np.unique(table["seed"])
    probs = np.zeros((len(table["class_id"]), len(MATERIAL_IDS)))
    for start in range(0, len(seeds), seeds_per_fold):
        held = np.isin(table["seed"], seeds[start : start + seeds_per_fold])
        clf = ItemClassifier(table["features"][~held], table["class_id"][~held], seed=FIT_SEED)
        probs[held] = clf.probabilities(table["features"][held])
    return probs


def rule_curve(probs: np.ndarray, class_ids: np.ndarray, thresholds) -> list[tuple]:
    """Per threshold: (threshold, wrong items still offered, right items left on the belt,
    share of right items left)."""
    guess = np.asarray(MATERIAL_IDS)[np.argmax(probs, axis=1)]
    wrong = guess != class_ids
    sure = probs.max(axis=1)
    rows = []
    for t in thresholds:
        offered = sure >= t
        left_right = int(np.sum(~wrong & ~offered))
        rows.append((t, int(np.sum(wrong & offered)), left_right, left_right / max(len(wrong), 1)))
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim.evaluation.item_classifier_cv")
    parser.add_argument("--table", type=Path, default=TRAINING_TABLE)
    parser.add_argument("--thresholds", type=float, nargs="+", default=list(THRESHOLDS))
    args = parser.parse_args(argv)
    table = load_table(args.table)
    probs = out_of_fold_probabilities(table)
    truth = table["class_id"]
    wrong = np.asarray(MATERIAL_IDS)[np.argmax(probs, axis=1)] != truth
    n_seeds = len(np.unique(table["seed"]))
    print(
        f"{args.table}: {len(truth)} items of {n_seeds} seeds, folds of {SEEDS_PER_FOLD} seeds: "
        f"{int(wrong.sum())} wrong ({wrong.mean():.2%})"
    )
    print(errors_by_type(table, np.ones(len(truth), bool), probs, mode="the classifier's"))
    print("| min_class_confidence | wrong items offered | right items left on the belt |")
    print("|---|---|---|")
    for t, wrong_offered, left, share in rule_curve(probs, truth, args.thresholds):
        print(f"| {t:g} | {wrong_offered} | {left} ({share:.1%}) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
