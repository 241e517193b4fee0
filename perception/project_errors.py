"""The project's one exception root, shared by `perception`, `planner` and `sim`.

Every error raised on purpose derives from `SortsimError`; `RefusedInput` is the one-line
refusal (a field, what is allowed, what was given) that the command line turns into exit code 2.
Each package raises it under its own name (`PerceptionInputError`, `PlannerInputError`,
`InvalidInput`). This module imports nothing, so every layer may import it (the shared base of
docs/architecture.md, checked by tests/test_layering.py); it sits in `perception` only because
that is the lowest package, whose `__init__` loads nothing. Every class pickles with its fields,
so a refusal raised in a sweep's worker process reaches the parent intact.
"""

from __future__ import annotations


class SortsimError(Exception):
    """Base of every error the project raises on purpose."""


class RefusedInput(SortsimError, ValueError):
    """A refused input: names the field, where, what was given and what is allowed.

    Args:
        field: The refused field (a config key, an option, a file).
        allowed: What is allowed, in words.
        got: What was given (omitted from the message when None).
        where: The file or grid point it came from, if any.
    """

    def __init__(self, field: str, allowed: str, got: object = None, where: str | None = None):
        self.field = field
        self.allowed = allowed
        self.got = got
        self.where = where
        got_text = "" if got is None else f" (got {got!r})"
        where_text = f" in {where}" if where else ""
        super().__init__(f"{field}{where_text}: allowed {allowed}{got_text}")

    def __reduce__(self):
        return (type(self), (self.field, self.allowed, self.got, self.where))
