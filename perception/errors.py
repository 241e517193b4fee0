"""Perception's own errors, under the project's root (`perception.project_errors`)."""

from __future__ import annotations

from perception.project_errors import RefusedInput, SortsimError

__all__ = ["PerceptionError", "PerceptionInputError", "RefusedInput", "SortsimError"]


class PerceptionInputError(RefusedInput):
    """A perception parameter or file that is refused."""


class PerceptionError(SortsimError, RuntimeError):
    """A frame that cannot be used (wrong shape, all black, markers not found)."""
