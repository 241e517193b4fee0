"""Online filtering: equal to the batch filter, bounded re-estimation, flat cost per row."""

from __future__ import annotations

import time

import numpy as np
import pytest

from perception.errors import PerceptionInputError
from perception.hmm.online import OnlineConfig, OnlineStripeHmms
from perception.hmm.stripes import infer
from perception.hmm.training import count_models


def model_and_grid(coupled: bool, rows: int = 120, seed: int = 0):
    rng = np.random.default_rng(seed)
    cls = np.ones((rows, 5), dtype=int)
    for _ in range(rows // 2):
        r, s = rng.integers(0, rows - 3), rng.integers(0, 4)
        cls[r : r + rng.integers(1, 4), s : s + rng.integers(1, 3)] = rng.integers(2, 5)
    colour = {1: [19], 2: [2, 3, 8, 9, 14, 15], 3: [1, 4, 6, 7, 13, 16], 4: [4, 5, 10, 11, 17]}
    codes = np.vectorize(lambda c: rng.choice(colour[c]))(cls)
    return count_models([cls], [codes], coupled=coupled), cls, codes


@pytest.mark.parametrize("coupled", [False, True])
def test_online_filter_equals_batch_filter_without_reestimation(coupled):
    models, _, codes = model_and_grid(coupled)
    online = OnlineStripeHmms(models, OnlineConfig(reestimate_every=0))
    rows = [online.step(row) for row in codes]
    batch = infer(models, codes.T)
    filt = np.stack([r.filtered for r in rows], axis=1)
    pred = np.stack([r.predicted for r in rows], axis=1)
    assert np.max(np.abs(filt - batch["filtered"])) < 1e-12
    assert np.max(np.abs(pred - batch["predicted"])) < 1e-12
    assert np.array_equal(np.stack([r.classes for r in rows]), np.argmax(filt, axis=2).T + 1)


def test_reestimation_updates_models_and_keeps_them_stochastic():
    models, cls, codes = model_and_grid(True)
    online = OnlineStripeHmms(models, OnlineConfig(window=30, reestimate_every=5, anchor=20.0))
    hits = [online.step(row).classes == c for row, c in zip(codes, cls, strict=True)]
    assert not np.allclose(online.models.B, models.B)
    assert np.allclose(online.models.A.sum(axis=-1), 1.0)
    assert np.mean(hits) > 0.9
    smoothed = online.smoothed_window()
    assert smoothed.shape == (30, 5, 4) and np.allclose(smoothed.sum(axis=2), 1.0)


def test_per_row_cost_is_flat_in_episode_length():
    """A filter 2300 rows into its episode steps as fast as one 50 rows in (timed interleaved,
    so that the machine's load weighs on both alike)."""
    models, _, codes = model_and_grid(True)
    cfg = OnlineConfig(window=20, reestimate_every=1)
    long, short = OnlineStripeHmms(models, cfg), OnlineStripeHmms(models, cfg)
    for r in range(2300):
        long.step(codes[r % len(codes)])
    for r in range(50):
        short.step(codes[r % len(codes)])
    times = {"long": [], "short": []}
    for r in range(300):
        for name, online in (("long", long), ("short", short)):
            t0 = time.perf_counter()
            online.step(codes[r % len(codes)])
            times[name].append(time.perf_counter() - t0)
    ratio = np.median(times["long"]) / np.median(times["short"])
    assert ratio < 1.3, ratio
    assert long._codes.shape == short._codes.shape == (20, 5)


def test_refuses_bad_rows_and_config():
    models, _, _ = model_and_grid(False)
    online = OnlineStripeHmms(models)
    with pytest.raises(PerceptionInputError, match="codes_row"):
        online.step(np.array([19, 19, 19]))
    with pytest.raises(PerceptionInputError, match="obs"):
        online.step(np.array([19, 19, 19, 19, 20]))
    with pytest.raises(PerceptionInputError) as err:
        OnlineConfig(window=1)
    assert err.value.field == "window"


def test_online_evaluation_equals_batch_filtered_evaluation():
    from perception.hmm.evaluation import evaluate, evaluate_online

    models, cls, codes = model_and_grid(True, seed=3)
    batch = evaluate(models, [cls], [codes], decode="filtered")
    online = evaluate_online(models, [cls], [codes], OnlineConfig(reestimate_every=0))
    assert np.array_equal(batch.decoded[0], online.decoded[0])
    assert np.allclose(batch.table, online.table, equal_nan=True)
    assert batch.prediction_accuracy == online.prediction_accuracy
