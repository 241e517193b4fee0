"""The thesis's HMM scores (section 4.1.1, table 4.1): per class, one-vs-rest, per stripe.

For class i: accuracy (TP + TN) / (P + N), sensitivity TP / P, specificity TN / N, precision
TP / (TP + FP). Each stripe's HMM is scored on all its rows, the five stripes are averaged per
class ("the per class average of all employed HMMs"), and the `Average` row is the mean over the
four classes. A ratio with a zero denominator (a class a stripe never saw or never predicted) is
undefined and left out of the averages.
"""

from __future__ import annotations

import warnings

import numpy as np

from perception.codes import CLASS_NAMES, N_STATES
from perception.errors import PerceptionInputError

STATS = ("accuracy", "sensitivity", "specificity", "precision")

# Table 4.1 of the thesis: rows classes 1..4 then Average; columns as STATS.
THESIS_TABLE_4_1 = np.array(
    [
        [0.8988, 0.917, 0.9233, 0.878],
        [0.8433, 0.92, 0.938, 0.8457],
        [0.9056, 0.84, 0.9307, 0.9211],
        [0.8788, 0.918, 0.8947, 0.8996],
        [0.8816, 0.8987, 0.9216, 0.8861],
    ]
)


def _ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1), np.nan)


def stripe_stats(truth, predicted) -> np.ndarray:
    """(S, 4 classes, 4 stats) of predicted vs true classes, both (rows, S) in 1..4."""
    gt, pr = np.asarray(truth), np.asarray(predicted)
    if gt.shape != pr.shape or gt.ndim != 2:
        raise PerceptionInputError("predicted", f"a grid of the truth's shape {gt.shape}", pr.shape)
    out = np.empty((gt.shape[1], N_STATES, len(STATS)))
    for i in range(1, N_STATES + 1):
        pos, hit = gt == i, pr == i
        tp = (pos & hit).sum(axis=0)
        tn = (~pos & ~hit).sum(axis=0)
        fp = (~pos & hit).sum(axis=0)
        p, n = pos.sum(axis=0), (~pos).sum(axis=0)
        out[:, i - 1] = np.stack(
            [_ratio(tp + tn, p + n), _ratio(tp, p), _ratio(tn, n), _ratio(tp, tp + fp)], axis=1
        )
    return out


def table_4_1(truth_grids, predicted_grids) -> np.ndarray:
    """(5, 4) table: classes 1..4 then Average, columns accuracy, sensitivity, specificity,
    precision; every stripe's rows of all grids pooled, then stripes averaged per class."""
    gt = np.concatenate([np.asarray(g) for g in truth_grids])
    pr = np.concatenate([np.asarray(g) for g in predicted_grids])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        per_class = np.nanmean(stripe_stats(gt, pr), axis=0)
        return np.vstack([per_class, np.nanmean(per_class, axis=0)])


def format_table(ours: np.ndarray, thesis: np.ndarray | None = THESIS_TABLE_4_1) -> str:
    """Table 4.1 as text, the thesis's value in brackets beside each of ours."""
    labels = [f"{i} {CLASS_NAMES[i - 1]}" for i in range(1, N_STATES + 1)] + ["Average"]
    head = f"{'class':<12}" + "".join(f"{s:>22}" for s in STATS)
    lines = [head]
    for r, label in enumerate(labels):
        cells = []
        for c in range(len(STATS)):
            ref = "" if thesis is None else f" ({thesis[r, c]:.4f})"
            cells.append(f"{ours[r, c]:.4f}{ref}")
        lines.append(f"{label:<12}" + "".join(f"{cell:>22}" for cell in cells))
    return "\n".join(lines)
