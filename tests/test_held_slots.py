"""The monitors' held-slot mask is `np.isin` of the held slots (None: none)."""

from __future__ import annotations

import numpy as np
import pytest

from sim.cell.held_slots import held_mask


@pytest.mark.parametrize(
    "held", [None, 3, np.int64(7), [], [3], [0, 7, 11], (5, 40), [2, 2], np.array([1, 9])]
)
def test_held_mask_is_isin(held):
    rng = np.random.default_rng(0)
    for slots in (np.arange(0), np.flatnonzero(rng.random(48) < 0.5), np.arange(12)):
        want = np.isin(slots, [] if held is None else held)
        got = held_mask(slots, held)
        assert got.dtype == bool and np.array_equal(got, want), (slots, held)
