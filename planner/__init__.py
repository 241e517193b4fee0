"""Motion planning and decision making: delta kinematics, ruckig trajectories, pick choice.

Pure: takes arrays and dataclasses, never MuJoCo data. The public API is re-exported here lazily
(PEP 562), so importing one submodule does not import them all.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "DeltaGeometry": "kinematics",
    "inverse_kinematics": "kinematics",
    "forward_kinematics": "kinematics",
    "is_reachable": "kinematics",
    "jacobian": "kinematics",
    "Unreachable": "kinematics",
    "MotionLimits": "limits",
    "limits_for_payload": "limits",
    "State": "trajectory",
    "Chain": "trajectory",
    "RuckigTrajectoryGenerator": "ruckig_trajectory",
    "PickPlaceConfig": "pick_cycle",
    "plan_pick_place": "pick_cycle",
    "plan_cycle1": "pick_cycle",
    "Intercept": "intercept",
    "intercept_item": "intercept",
    "CycleTimeModel": "cycle_model",
    "TrackedItem": "decision",
    "RobotState": "decision",
    "DecisionContext": "decision",
    "Choice": "decision",
    "make_planner": "registry",
    "PlannerInputError": "errors",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
