"""Planners by name: `make_planner('qlearning', gamma=0.9)`; unknown names and options refused."""

from __future__ import annotations

import dataclasses

from planner.decision import DecisionManager
from planner.errors import PlannerInputError
from planner.fifo import FifoPlanner
from planner.greedy import GreedyPlanner
from planner.oracle import OraclePlanner
from planner.proximity import ProximityPlanner
from planner.qlearning import QLearningConfig, QLearningPlanner

PLANNERS = ("qlearning", "proximity", "fifo", "greedy", "oracle")
_OPTIONS = {
    "qlearning": tuple(f.name for f in dataclasses.fields(QLearningConfig)),
    "proximity": (),
    "fifo": (),
    "greedy": (),
    "oracle": ("max_items",),
}


def make_planner(name: str, **params) -> DecisionManager:
    """A new decision manager.

    Args:
        name: One of PLANNERS.
        **params: Options of that planner (qlearning: the fields of QLearningConfig; oracle:
            max_items; the others take none).

    Raises:
        PlannerInputError: Unknown name or option, or an option out of range.
    """
    if name not in PLANNERS:
        raise PlannerInputError("planner", " | ".join(PLANNERS), name)
    unknown = sorted(set(params) - set(_OPTIONS[name]))
    if unknown:
        allowed = ", ".join(_OPTIONS[name]) or "no options"
        raise PlannerInputError(f"{name} option {unknown[0]}", allowed, params[unknown[0]])
    if name == "qlearning":
        return QLearningPlanner(QLearningConfig(**params))
    if name == "oracle":
        return OraclePlanner(**params)
    return {"proximity": ProximityPlanner, "fifo": FifoPlanner, "greedy": GreedyPlanner}[name]()
