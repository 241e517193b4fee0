"""Perception's errors: refused input (exit code 2) and unusable frames (logged, survived)."""

from __future__ import annotations


class PerceptionInputError(ValueError):
    """A perception parameter or file that is refused: names the field and the allowed values."""

    def __init__(self, field: str, allowed: str, got: object = None):
        self.field = field
        self.allowed = allowed
        self.got = got
        got_text = "" if got is None else f" (got {got!r})"
        super().__init__(f"{field}: allowed {allowed}{got_text}")


class PerceptionError(RuntimeError):
    """A frame that cannot be used (wrong shape, all black, markers not found)."""
