"""The planner's errors, under the project's root (`perception.project_errors`): its refused
input and a decision manager that misbehaved."""

from __future__ import annotations

from perception.project_errors import RefusedInput, SortsimError


class PlannerInputError(RefusedInput):
    """A planner parameter out of range: names the field and the allowed values."""


class PlannerError(SortsimError):
    """A decision manager or planner that did something it must not (not a refused input:
    the command line says it in one line, exit code 1)."""
