"""The planner's refused input: the project's one refusal (`perception.errors.RefusedInput`)."""

from __future__ import annotations

from perception.errors import RefusedInput


class PlannerInputError(RefusedInput):
    """A planner parameter out of range: names the field and the allowed values."""
