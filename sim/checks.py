"""Checks of single values, shared by every room of the simulation side.

Settings, files and options are refused in one line naming the field and what is allowed
(`sim.errors.InvalidInput`); the tests a value must pass before that refusal are the same
everywhere, so they live here once. Like `sim.paths` and `sim.errors`, this module imports
nothing else of the project but `sim.errors` (any room may import it, docs/architecture.md).

A number is an `int` or a `float` and never a `bool` (TOML's and JSON's `true` would otherwise
pass as 1). `is_number` lets NaN and infinities through, so a range check after it decides
(`0.0 <= nan` is false); `is_finite_number` refuses them itself.
"""

from __future__ import annotations

import math
from typing import TypeGuard

from sim.errors import InvalidInput

__all__ = ["check", "is_finite_in", "is_finite_number", "is_integer", "is_number"]


def is_number(value: object) -> TypeGuard[int | float]:
    """Whether `value` is a real number (an int or a float, not a bool; NaN and inf included).

    Args:
        value: Anything, as a config file or a caller gives it.

    Returns:
        True for an int or float that is not a bool.
    """
    return isinstance(value, int | float) and not isinstance(value, bool)


def is_finite_number(value: object) -> TypeGuard[int | float]:
    """Whether `value` is a real number (`is_number`) and finite (not NaN, not +-inf).

    Args:
        value: Anything, as a config file or a caller gives it.

    Returns:
        True for a finite int or float that is not a bool.
    """
    return is_number(value) and math.isfinite(value)


def is_finite_in(value: object, lo: float, hi: float) -> bool:
    """Whether `value` is a finite real number in the closed range [`lo`, `hi`].

    Args:
        value: Anything, as a config file or a caller gives it.
        lo: Smallest value allowed (in the value's unit).
        hi: Largest value allowed (in the value's unit).

    Returns:
        True for a finite int or float (not a bool) with lo <= value <= hi.
    """
    return is_finite_number(value) and lo <= value <= hi


def is_integer(value: object) -> TypeGuard[int]:
    """Whether `value` is a Python int and not a bool (a float of integer value is not).

    Args:
        value: Anything, as a config file or a caller gives it.

    Returns:
        True for an int that is not a bool.
    """
    return isinstance(value, int) and not isinstance(value, bool)


def check(ok: bool, key: str, allowed: str, got: object, where: str | None = None) -> None:
    """Refuse `got` in one line unless `ok`.

    Args:
        ok: Whether the value passed its checks.
        key: The refused field as the user names it (`robots[1].pick_pause_s`, `--workers`).
        allowed: What is allowed, in words (`0..2 s`).
        got: What was given (left out of the message when None).
        where: The file or grid point it came from, if any.

    Raises:
        InvalidInput: When not `ok`: "`key` in `where`: allowed `allowed` (got `got`)".
    """
    if not ok:
        raise InvalidInput(key, allowed, got, where)
