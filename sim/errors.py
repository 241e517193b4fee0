"""Errors the command line turns into exit codes.

Every refusal derives from `perception.errors.RefusedInput` (the project's one root, importable
by the pure packages too): the CLI prints its one-line message and exits with code 2. Anything
else is a bug or an environment failure: exit code 1.
"""

from __future__ import annotations

from perception.errors import RefusedInput, SortsimError

__all__ = ["InvalidInput", "ModelFileError", "RefusedInput", "SortsimError"]


class InvalidInput(RefusedInput):
    """A refused input of the simulation side (config, files, options)."""


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

    def __reduce__(self):
        return (type(self), (self.path, self.reason))
