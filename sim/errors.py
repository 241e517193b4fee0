"""Errors the command line turns into exit codes.

`InvalidInput` (and the matching classes of `planner` and `perception`, which cannot import
`sim`) means the user asked for something we refuse: the CLI prints its one-line message and
exits with code 2. Anything else is a bug or an environment failure: exit code 1.
"""

from __future__ import annotations


class SortsimError(Exception):
    """Base of every error this package raises on purpose."""


class InvalidInput(SortsimError, ValueError):
    """A refused input: names the field, what was given and what is allowed."""

    def __init__(self, field: str, allowed: str, got: object = None, where: str | None = None):
        self.field = field
        self.allowed = allowed
        self.got = got
        self.where = where
        got_text = "" if got is None else f" (got {got!r})"
        where_text = f" in {where}" if where else ""
        super().__init__(f"{field}{where_text}: allowed {allowed}{got_text}")


class ModelFileError(InvalidInput):
    """An MJCF file that is missing or does not compile."""

    def __init__(self, path: object, reason: str):
        self.path = path
        self.reason = reason
        SortsimError.__init__(self, f"model file {path}: {reason}")
        self.field = "model"
        self.allowed = "an existing, compilable MJCF file"
        self.got = path
        self.where = None


class NotAvailable(SortsimError):
    """A command whose implementation has not landed yet (exit code 2)."""
