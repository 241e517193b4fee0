"""The pool slots the cups hold: one type for one robot's cup or a line's cups.

The item monitors (`sim.cell.riding`, `sim.monitors.bins`, `sim.monitors.thrown`) take the
held slots as an int array, robot by robot (empty: no cup holds an item), and leave those items
out every few milliseconds of simulated time.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

NONE_HELD = np.empty(0, dtype=int)
"""No cup holds an item."""


def held_slots(slots: Iterable[int | None] | int | None) -> np.ndarray:
    """The held slots as the monitors take them: an int array (n,), from each cup's
    `held_slot` (None: that cup holds nothing), a single slot, or None.

    Args:
        slots: Each cup's held slot or None, a single slot, or None.

    Returns:
        The slots held, in the order given, as an int array (empty: none).
    """
    if slots is None:
        return NONE_HELD
    if isinstance(slots, int | np.integer):
        return np.array([int(slots)], dtype=int)
    return np.array([int(s) for s in slots if s is not None], dtype=int)


def held_mask(slots: np.ndarray, held: np.ndarray) -> np.ndarray:
    """(n,) bool: which of the pool `slots` (n,) are held; equal to `np.isin(slots, held)` for
    the at most one slot per cup, at a fraction of its cost (no sorting).

    Args:
        slots: Pool slots (n,).
        held: The held slots (`held_slots`).
    """
    mask = np.zeros(len(slots), dtype=bool)
    for slot in held.tolist():
        mask |= slots == slot
    return mask
