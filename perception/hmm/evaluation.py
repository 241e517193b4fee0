"""Scores trained stripe HMMs on held-out labelled grids (thesis 4.1.1, table 4.1).

Decoding, as in the thesis's annex, takes each cell's most probable class under the smoothed
posterior gamma (`posterior`), or under the filtered posterior an online decoder has
(`filtered`). The one-step prediction is the class distribution of a row computed before the row
is observed, P(q_t | o_1..t-1); its accuracy is scored on all cells and on the occupied ones.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from perception.codes import VOID
from perception.errors import PerceptionInputError
from perception.hmm.metrics import table_4_1
from perception.hmm.online import OnlineConfig, OnlineStripeHmms
from perception.hmm.stripes import StripeHmms, infer
from perception.hmm.training import TrainConfig, train

DECODERS = ("posterior", "filtered")


@dataclass(frozen=True, eq=False)
class Evaluation:
    """Scores of one model on a set of grids.

    Attributes:
        table: (5, 4) table 4.1 of the decoded classes (classes 1..4, Average).
        prediction_table: (5, 4) table 4.1 of the one-step predictions.
        prediction_accuracy: Share of cells whose class the one-step prediction got right.
        prediction_accuracy_items: The same over cells holding an item.
        cell_accuracy: Share of cells decoded right.
        loglik_per_row: Mean log-likelihood of a row of codes [nats].
        decoded: (rows, S) decoded classes of each grid.
        posteriors: (rows, S, N) the posteriors decoded, per grid.
    """

    table: np.ndarray
    prediction_table: np.ndarray
    prediction_accuracy: float
    prediction_accuracy_items: float
    cell_accuracy: float
    loglik_per_row: float
    decoded: list
    posteriors: list


def evaluate(models: StripeHmms, classes_grids, codes_grids, decode: str = "posterior"):
    """Decode every (rows, S) code grid and score it against its true classes."""
    if decode not in DECODERS:
        raise PerceptionInputError("decode", "/".join(DECODERS), decode)
    decoded, posts, predicted, loglik, rows = [], [], [], 0.0, 0
    for codes in codes_grids:
        out = infer(models, np.asarray(codes).T)
        post = out["smoothed" if decode == "posterior" else "filtered"].transpose(1, 0, 2)
        posts.append(post)
        decoded.append(np.argmax(post, axis=2) + 1)
        predicted.append(np.argmax(out["predicted"], axis=2).T + 1)
        loglik += float(out["loglik"].sum())
        rows += post.shape[0]
    return _score(classes_grids, decoded, predicted, posts, loglik / max(rows, 1))


def evaluate_online(models: StripeHmms, classes_grids, codes_grids, config: OnlineConfig):
    """Run the online filter row by row over each grid (re-estimating as configured) and score
    its filtered decoding and one-step predictions like `evaluate` (loglik_per_row is NaN)."""
    decoded, posts, predicted = [], [], []
    for codes in codes_grids:
        online = OnlineStripeHmms(models, config)
        rows = [online.step(row) for row in np.asarray(codes)]
        decoded.append(np.stack([r.classes for r in rows]))
        posts.append(np.stack([r.filtered for r in rows]))
        predicted.append(np.stack([np.argmax(r.predicted, axis=1) + 1 for r in rows]))
    return _score(classes_grids, decoded, predicted, posts, float("nan"))


def _score(classes_grids, decoded, predicted, posts, loglik_per_row) -> Evaluation:
    truth = [np.asarray(c) for c in classes_grids]
    gt, dec, pred = (np.concatenate(x) for x in (truth, decoded, predicted))
    occupied = gt != VOID
    return Evaluation(
        table=table_4_1(truth, decoded),
        prediction_table=table_4_1(truth, predicted),
        prediction_accuracy=float(np.mean(pred == gt)),
        prediction_accuracy_items=float(np.mean(pred[occupied] == gt[occupied])),
        cell_accuracy=float(np.mean(dec == gt)),
        loglik_per_row=loglik_per_row,
        decoded=decoded,
        posteriors=posts,
    )


def train_and_score(
    train_classes,
    train_codes,
    extra_codes,
    test_classes,
    test_codes,
    options: TrainConfig | None = None,
    decode: str = "posterior",
) -> dict[tuple[bool, str], tuple[StripeHmms, Evaluation]]:
    """Train the stripe HMMs independent and coupled, each counted (thesis 3.2.2) and
    re-estimated (3.2.3), and score each on held-out grids (table 4.1).

    Args:
        train_classes: (rows, S) true class grids of the labelled training recordings.
        train_codes: Their (rows, S) code grids.
        extra_codes: Code grids that join the re-estimation unlabelled.
        test_classes: Held-out true class grids.
        test_codes: Their code grids.
        options: How to train (`TrainConfig`; its `coupled` is set here, both ways).
        decode: `posterior` or `filtered` decoding.

    Returns:
        {(coupled, "counted" | "re-estimated"): (models, their `Evaluation`)}.
    """
    options = TrainConfig() if options is None else options
    results = {}
    for coupled in (False, True):
        config = dataclasses.replace(options, coupled=coupled)
        initial, trained = train(train_classes, train_codes, extra_codes, config)
        for stage, models in (("counted", initial), ("re-estimated", trained)):
            scores = evaluate(models, test_classes, test_codes, decode)
            results[coupled, stage] = (models, scores)
    return results
