"""One robot of a cell, as its pick controller and the episode see it.

A cell holds one to four IRB 360s over one belt (one robot is a line of one). Each robot's
named parts carry its name prefix in the compiled model ("" for a lone robot, wherever it
stands; `r0_`, `r1_`, ... on a line of several, `sim.model.line_model`). A `RobotView` gathers
what belongs to that robot alone: its geometry read from the MJCF, its trajectory generator and
executor, its reachable window along the belt and its bins' release points. Model, data, belt
and items are the cell's, shared by every robot.
"""

from __future__ import annotations

import dataclasses
from typing import cast

import mujoco
import numpy as np

from planner.motion.kinematics import reachable_mask
from planner.motion.limits import limits_for_payload
from planner.motion.reach_window import ReachWindow
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from sim.cell.executor import TrajectoryExecutor, lumped_dynamics
from sim.cell.robot import geometry_from_model, tcp_position

PICK_Z_NOMINAL = 0.02
"""TCP height of the reachable window the planners use (a typical item top) [m]."""
DESIGN_PAYLOAD_KG = 1.0
"""Payload the pick trajectories are planned for: the heaviest catalogue item is well under it."""


class RobotView:
    """One robot of a cell: its geometry, trajectories, window and bins.

    Args:
        model: The compiled cell.
        data: Its data (poses read at construction: bins' release points).
        index: The robot's index, 0 upstream.
        prefix: Its name prefix in `model` ("" for a lone robot: the scene's own names).
        materials: The catalogue's materials (one bin each, in material order).
    """

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, index: int, prefix: str, materials
    ):
        self.index, self.prefix = int(index), prefix
        self._model, self._data = model, data
        self.geometry = geometry_from_model(model, prefix=prefix)
        self.limits = limits_for_payload(DESIGN_PAYLOAD_KG)
        dynamics = lumped_dynamics(model, self.geometry, DESIGN_PAYLOAD_KG, prefix=prefix)
        self.generator = RuckigTrajectoryGenerator(self.limits, self.geometry, dynamics)
        self.executor = TrajectoryExecutor(model, data, geometry=self.geometry, prefix=prefix)
        # The window of the same robot at the origin, moved to this robot's base (the window
        # is searched about the origin).
        base_x, base_y = self.geometry.base_xy
        at_origin = dataclasses.replace(self.geometry, base_xy=(0.0, base_y))
        self.window = ReachWindow.from_reachable(
            lambda p: reachable_mask(at_origin, p), PICK_Z_NOMINAL
        ).shifted(base_x)
        """Where this robot reaches items on the belt, at `PICK_Z_NOMINAL`."""
        mujoco.mj_forward(model, data)
        self.drop_xyz = {
            c: data.site(f"{prefix}bin_{name}_drop").xpos.copy()
            for c, name in zip(materials.ids, materials.names, strict=True)
        }
        """Release point over each material's bin, by class id [m]."""
        self.base_x = float(base_x)
        """x of the robot's base centre along the belt [m]."""
        self.cup_radius = float(model.geom(f"{prefix}cup_collision").size[0])
        """Radius of the cup's lip [m] (the model's)."""

    def bins_tuple(self) -> tuple[tuple[float, float, float], ...]:
        """Release points of this robot's bins, in material order, for the planners [m]."""
        xyz = (tuple(float(v) for v in self.drop_xyz[c]) for c in self.drop_xyz)
        return tuple(cast(tuple[float, float, float], p) for p in xyz)

    def tcp(self) -> np.ndarray:
        """This robot's cup lip centre now [m], (3,)."""
        return tcp_position(self._model, self._data, prefix=self.prefix)
