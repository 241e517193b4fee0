"""Table 4.1 statistics: hand-checked one-vs-rest counts and stripe averaging."""

from __future__ import annotations

import numpy as np
import pytest

from perception.errors import PerceptionInputError
from perception.hmm.metrics import THESIS_TABLE_4_1, format_table, stripe_stats, table_4_1


def test_one_vs_rest_counts_by_hand():
    truth = np.array([[1], [1], [2], [3], [4], [2]])
    pred = np.array([[1], [2], [2], [3], [3], [2]])
    s = stripe_stats(truth, pred)[0]
    # class 2: P = 2, TP = 2, FP = 1, TN = 3 of N = 4
    assert np.allclose(s[1], [5 / 6, 1.0, 3 / 4, 2 / 3])
    # class 4: never predicted -> precision undefined
    assert np.isnan(s[3, 3]) and np.isclose(s[3, 1], 0.0)


def test_table_averages_stripes_then_classes():
    rng = np.random.default_rng(0)
    truth = rng.integers(1, 5, size=(200, 5))
    pred = np.where(rng.random((200, 5)) < 0.9, truth, rng.integers(1, 5, size=(200, 5)))
    table = table_4_1([truth[:100], truth[100:]], [pred[:100], pred[100:]])
    assert table.shape == (5, 4)
    assert np.allclose(table[:4], stripe_stats(truth, pred).mean(axis=0))
    assert np.allclose(table[4], table[:4].mean(axis=0))
    assert table[4, 0] > 0.9
    text = format_table(table)
    assert "Average" in text and f"({THESIS_TABLE_4_1[4, 0]:.4f})" in text


def test_shape_mismatch_is_refused():
    with pytest.raises(PerceptionInputError, match="predicted"):
        stripe_stats(np.ones((3, 5), int), np.ones((3, 4), int))
