"""The thesis's comparison picker (section 4.2): the nearest reachable item first, blind to value.

It knows the belt's speed and the robot's timing (only items it can still meet are candidates),
but chooses on distance alone: the straight-line distance from the TCP to the meeting point.
"""

from __future__ import annotations

import math

from planner.decision.candidates import candidates, choice_of
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem


class ProximityPlanner:
    """Nearest meeting point first; ties go to the item that leaves the window first."""

    name = "proximity"

    def reset(self) -> None:
        """Stateless."""

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """The reachable item whose meeting point is nearest to the TCP."""
        cands = candidates(items, robot, context, immediate_only=True, with_place=False)
        if not cands:
            return None
        tx, ty, tz = robot.tcp
        z = context.window.pick_z

        def distance(c):
            return math.dist((tx, ty, tz), (c.meet_xy[0], c.meet_xy[1], z))

        best = min(cands, key=distance)
        return choice_of(best, f"nearest: {distance(best):.3f} m")
