"""The cell as the decision managers see it, read once from the compiled scene (for the decision
tests and benchmark).

Geometry, bins and limits come from the MJCF through `sim` (as the episode runner reads them);
the planners themselves never touch MuJoCo.
"""

from __future__ import annotations

import functools

import mujoco

from perception.codes import THESIS_VALUES_EUR
from planner.decision.interface import DecisionContext
from planner.motion.kinematics import reachable_mask
from planner.motion.limits import VACUUM_RELEASE_S, VACUUM_SEAL_S, limits_for_payload
from planner.motion.reach_window import ReachWindow

PICK_Z = 0.02  # TCP height at contact, as the episode runner uses [m]
PAYLOAD_KG = 1.0  # the payload the runner plans trajectories for


@functools.lru_cache(maxsize=1)
def cell_parts():
    """(window, bins, cycle model) of the scene in models/cell."""
    from sim.cell.conveyor import rail_top_z
    from sim.cell.robot import geometry_from_model
    from sim.episode.cycle_timing import cell_cycle_model
    from sim.episode.pick_control import PRESS_DEPTH_M, clear_height
    from sim.flow.catalogue import load_catalogue
    from sim.model.mjcf import load_scene

    model = load_scene()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    geometry = geometry_from_model(model)
    window = ReachWindow.from_reachable(lambda p: reachable_mask(geometry, p), PICK_Z)
    bins = tuple(
        tuple(float(c) for c in data.site(f"bin_{name}_drop").xpos)
        for name in ("paper", "plastic", "aluminium")
    )
    # The lift the episode runner makes: a held item's bottom up to the clear height.
    lift = clear_height(load_catalogue(), rail_top_z(model)) + PRESS_DEPTH_M
    model_t = cell_cycle_model(
        limits_for_payload(PAYLOAD_KG), PICK_Z, lift, VACUUM_SEAL_S, VACUUM_RELEASE_S
    )
    return window, bins, model_t


def cell_context(belt_speed: float, values=THESIS_VALUES_EUR) -> DecisionContext:
    """Decision context of the cell at `belt_speed` [m/s] with its calibrated cycle model."""
    window, bins, model_t = cell_parts()
    return DecisionContext(belt_speed, model_t, window, bins, tuple(values))
