"""The planner's errors: its refused input, the project's one refusal
(`perception.errors.RefusedInput`), and a decision manager that misbehaved."""

from __future__ import annotations

from perception.errors import RefusedInput, SortsimError


class PlannerInputError(RefusedInput):
    """A planner parameter out of range: names the field and the allowed values."""


class PlannerError(SortsimError):
    """A decision manager or planner that did something it must not (not a refused input:
    the command line says it in one line, exit code 1)."""
