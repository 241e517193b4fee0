"""The project's one exception root, and perception's own errors.

Every error raised on purpose derives from `SortsimError`. `RefusedInput` is the one-line
refusal (a field, what is allowed, what was given) that the command line turns into exit code 2;
`sim`, `planner` and `perception` each raise it under their own name. It lives here, the lowest
layer, because `planner` and `perception` are pure and import nothing of `sim` (the layering in
docs/architecture.md). Every class pickles with its fields, so a refusal raised in a sweep's
worker process reaches the parent intact.
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


class PerceptionInputError(RefusedInput):
    """A perception parameter or file that is refused."""


class PerceptionError(SortsimError, RuntimeError):
    """A frame that cannot be used (wrong shape, all black, markers not found)."""
