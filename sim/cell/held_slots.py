"""The pool slots the cups hold, as the item monitors are given them.

The monitors (`sim.cell.riding`, `sim.monitors.bins`, `sim.monitors.thrown`) take the held
slots as None (no cup holds an item), one slot (one robot's cup) or a sequence of them (a
line's cups), and leave those items out every few milliseconds of simulated time.
"""

from __future__ import annotations

import numpy as np


def held_mask(slots: np.ndarray, held_slot) -> np.ndarray:
    """(n,) bool: which of the pool `slots` (n,) are held; equal to `np.isin(slots,
    held_slot)` (None counting as no slot) for the at most one slot per cup, at a fraction of
    its cost (no sorting)."""
    held = np.zeros(len(slots), dtype=bool)
    if held_slot is None:
        return held
    for slot in (held_slot,) if isinstance(held_slot, int | np.integer) else held_slot:
        held |= slots == slot
    return held
