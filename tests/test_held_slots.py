"""The held slots as one type: an int array from each cup's `held_slot` (None: holds nothing),
and the monitors' mask of them equal to `np.isin`."""

from __future__ import annotations

import numpy as np
import pytest

from sim.cell.held_slots import NONE_HELD, held_mask, held_slots


@pytest.mark.parametrize(
    "given, want",
    [
        (None, []),
        (3, [3]),
        (np.int64(7), [7]),
        ([], []),
        ([None, None], []),
        ([3, None], [3]),
        ([None, 0, 7, 11], [0, 7, 11]),
        ((5, 40), [5, 40]),
        (np.array([1, 9]), [1, 9]),
    ],
)
def test_held_slots_are_an_int_array_of_the_cups_slots(given, want):
    held = held_slots(given)
    assert held.dtype.kind == "i" and held.tolist() == want


@pytest.mark.parametrize("held", [[], [3], [0, 7, 11], [5, 40], [2, 2], [1, 9]])
def test_held_mask_is_isin(held):
    rng = np.random.default_rng(0)
    held = held_slots(held)
    for slots in (np.arange(0), np.flatnonzero(rng.random(48) < 0.5), np.arange(12)):
        got = held_mask(slots, held)
        assert got.dtype == bool and np.array_equal(got, np.isin(slots, held)), (slots, held)


def test_nothing_held_masks_nothing():
    slots = np.arange(10)
    assert not held_mask(slots, NONE_HELD).any()
    assert len(NONE_HELD) == 0
