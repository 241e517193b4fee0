"""The planner's refused-input error (the CLI maps it to exit code 2)."""

from __future__ import annotations


class PlannerInputError(ValueError):
    """A planner parameter out of range: names the field and the allowed values."""

    def __init__(self, field: str, allowed: str, got: object = None):
        self.field = field
        self.allowed = allowed
        self.got = got
        got_text = "" if got is None else f" (got {got!r})"
        super().__init__(f"{field}: allowed {allowed}{got_text}")
