"""What the environments do with an action their mask rules out (`invalid_action`).

An action is a slot index 0..K-1 (pick the candidate there) or K (wait); the action mask
(`action_masks()`, `info["action_mask"]`) marks the slots that hold a candidate, and wait,
which is always allowed. An action the mask rules out (an empty slot) or outside 0..K (or not
an integer) is:

- `"raise"` (the default): refused with one line naming the action, the allowed slots and the
  mask (`InvalidAction`, a `ValueError`), before anything is stepped;
- `"wait"`: taken as waiting (an empty slot picks nothing).
"""

from __future__ import annotations

import numbers
from typing import SupportsInt, cast

import numpy as np

from sim.errors import InvalidInput

INVALID_ACTIONS = ("raise", "wait")
"""What an environment may do with an action its mask rules out."""


class InvalidAction(InvalidInput):
    """An action the environment's mask rules out, or outside its action space."""


def check_invalid_action(value: object) -> str:
    """`value` as an `invalid_action` setting, refused unless one of `INVALID_ACTIONS`."""
    if value not in INVALID_ACTIONS:
        raise InvalidInput("invalid_action", " | ".join(f'"{v}"' for v in INVALID_ACTIONS), value)
    return str(value)


def _as_int(action: object) -> int | None:
    """The integer an action stands for (an int, a NumPy integer, a 0-d or 1-element array of
    one), or None."""
    if isinstance(action, np.ndarray) and action.size == 1:
        action = action.reshape(-1)[0]
    if isinstance(action, bool | np.bool_):
        return None
    if isinstance(action, numbers.Integral):
        return int(action)
    if isinstance(action, numbers.Real) and float(action).is_integer():
        return int(cast(SupportsInt, action))  # numbers.Real does not declare __int__
    return None


def slot_of(action: object, mask: np.ndarray, invalid_action: str = "raise") -> int:
    """The slot an action picks (the last index of `mask`: wait).

    Args:
        mask: The action mask now, (K + 1,) bool.
        invalid_action: "raise" or "wait" (module docstring).

    Returns:
        The slot 0..K-1 to pick, or K to wait.

    Raises:
        InvalidAction: With "raise", an action outside 0..K, not an integer, or ruled out by
            the mask.
    """
    wait = len(mask) - 1
    index = _as_int(action)
    if index is not None and 0 <= index <= wait and mask[index]:
        return index
    if invalid_action == "wait":
        if index is None:  # as before: whatever int() makes of it
            index = int(action)  # type: ignore[call-overload]  # any value: int() refuses the rest
        return index if 0 <= index < wait and mask[index] else wait
    allowed = [int(k) for k in np.flatnonzero(mask)]
    slots = ", ".join(str(k) for k in allowed[:-1]) or "none"
    what = (
        f"a slot holding a candidate ({slots}) or {wait} to wait: the action mask "
        "(action_masks(), info['action_mask'])"
    )
    if index is None or not 0 <= index <= wait:
        what = f"an integer 0..{wait}, " + what
    raise InvalidAction("action", what, action)
