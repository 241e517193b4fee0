"""Motion planning and decision making: delta kinematics, ruckig trajectories, pick choice.

Pure: takes arrays and dataclasses, never MuJoCo data. The public API is re-exported here lazily
(PEP 562), so importing one submodule does not import them all.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "DeltaGeometry": "motion.kinematics",
    "inverse_kinematics": "motion.kinematics",
    "forward_kinematics": "motion.kinematics",
    "is_reachable": "motion.kinematics",
    "jacobian": "motion.kinematics",
    "Unreachable": "motion.kinematics",
    "MotionLimits": "motion.limits",
    "limits_for_payload": "motion.limits",
    "State": "motion.trajectory",
    "Chain": "motion.trajectory",
    "RuckigTrajectoryGenerator": "motion.ruckig_trajectory",
    "PickPlaceConfig": "motion.pick_cycle",
    "plan_pick_place": "motion.pick_cycle",
    "plan_cycle1": "motion.pick_cycle",
    "Intercept": "motion.intercept",
    "intercept_item": "motion.intercept",
    "CycleTimeModel": "motion.cycle_model",
    "TrackedItem": "decision.interface",
    "RobotState": "decision.interface",
    "DecisionContext": "decision.interface",
    "Choice": "decision.interface",
    "make_planner": "decision.registry",
    "PlannerInputError": "errors",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
