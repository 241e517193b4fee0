"""Errors the command line turns into exit codes.

Every refusal derives from `RefusedInput` of the project's one root,
`perception.project_errors` (importable by the pure packages too): the CLI prints its one-line
message and exits with code 2. Anything else is a bug or an environment failure: exit code 1.
"""

from __future__ import annotations

from perception.project_errors import RefusedInput, SortsimError

__all__ = ["CallOrderError", "InvalidInput", "ModelFileError", "RefusedInput", "SortsimError"]


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


class CallOrderError(SortsimError, RuntimeError):
    """A method called when the object's state does not allow it (a fault of the calling code,
    not of the user's input: exit code 1)."""
