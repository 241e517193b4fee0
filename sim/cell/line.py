"""A sorting line's cell: several IRB 360s over one belt, each seen as a cell of its own.

`LineCell` owns the line's one MjModel/MjData, belt and item pool (as `Cell` does for one robot)
and a `RobotCell` per robot: the robot's named parts (its name prefix: `r0_`, `r1_`, ...), its
geometry, trajectory generator, executor, reachable window and bins, with the attributes of a
`Cell` the pick controller and the episode read, so that `PickController(robot_cell, ...,
prefix=...)` drives robot k as it drives the single cell's robot. The episode steps every
robot on its one loop (`sim.episode.loop.RobotStation`).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from planner.motion.kinematics import reachable_mask
from planner.motion.limits import limits_for_payload
from planner.motion.reach_window import ReachWindow
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from sim.cell.cell import DESIGN_PAYLOAD_KG, PICK_Z_NOMINAL, Cell
from sim.cell.conveyor import Belt
from sim.cell.executor import TrajectoryExecutor, lumped_dynamics
from sim.cell.item_pool import ItemPool
from sim.cell.riding import wake_line
from sim.cell.robot import geometry_from_model, tcp_position
from sim.flow.catalogue import Catalogue, load_catalogue
from sim.model.scene_edits import CUP_DIAMETER_M, CellSettings


class RobotCell:
    """One robot of a line, with the parts of a `Cell` its pick controller uses.

    Args:
        line: The line it belongs to (model, data, pool, belt, catalogue shared).
        prefix: The robot's name prefix in the line's model.
    """

    def __init__(self, line: LineCell, prefix: str):
        self.line, self.prefix = line, prefix
        self.model, self.data = line.model, line.data
        self.catalogue, self.materials = line.catalogue, line.materials
        self.pool, self.belt, self.settings = line.pool, line.belt, line.settings
        self.geometry = geometry_from_model(self.model, prefix=prefix)
        self.limits = limits_for_payload(DESIGN_PAYLOAD_KG)
        dynamics = lumped_dynamics(self.model, self.geometry, DESIGN_PAYLOAD_KG, prefix=prefix)
        self.generator = RuckigTrajectoryGenerator(self.limits, self.geometry, dynamics)
        self.executor = TrajectoryExecutor(
            self.model, self.data, geometry=self.geometry, prefix=prefix
        )
        # The window of the same robot at the origin, moved to this robot's base (the window
        # is searched about the origin).
        base_x, base_y = self.geometry.base_xy
        at_origin = dataclasses.replace(self.geometry, base_xy=(0.0, base_y))
        self.window = ReachWindow.from_reachable(
            lambda p: reachable_mask(at_origin, p), PICK_Z_NOMINAL
        ).shifted(base_x)
        mujoco.mj_forward(self.model, self.data)
        self.drop_xyz = {
            c: self.data.site(f"{prefix}bin_{name}_drop").xpos.copy()
            for c, name in zip(self.materials.ids, self.materials.names, strict=True)
        }
        self.base_x = float(base_x)

    def bins_tuple(self) -> tuple[tuple[float, float, float], ...]:
        """Release points of this robot's bins, in material order [m]."""
        return tuple(tuple(float(v) for v in self.drop_xyz[c]) for c in self.materials.ids)

    def tcp(self) -> np.ndarray:
        """This robot's cup lip centre now [m]."""
        return tcp_position(self.model, self.data, prefix=self.prefix)


class LineCell:
    """The compiled line (model, data), its belt and pool, and one `RobotCell` per robot.

    Args:
        model: The compiled line (`sim.model.line_model`).
        prefixes: The robots' name prefixes, upstream first.
        catalogue: The item catalogue (its materials name the bins); the default when None.
        settings: What the model was compiled with (cup, belt); the defaults when None.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        prefixes: tuple[str, ...],
        catalogue: Catalogue | None = None,
        settings: CellSettings | None = None,
    ):
        self.model = model
        self.data = mujoco.MjData(model)
        self.catalogue = catalogue if catalogue is not None else load_catalogue()
        self.materials = self.catalogue.materials
        self.settings = settings or CellSettings()
        self.belt = Belt(model)
        self.pool = ItemPool(model, self.catalogue, self.belt)
        self.robot_cells = [RobotCell(self, p) for p in prefixes]
        self._home_key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
        """Every robot at its home pose (`sim.model.line_model`)."""
        self.item_radius = max(
            float(self.pool.props(k)["geom_rbound"]) for k in range(len(self.catalogue.types))
        )
        """Largest bounding radius of a catalogue type at its nominal size [m]."""
        first = self.robot_cells[0]
        self.wake_x = wake_line(lambda p: reachable_mask(first.geometry, p), self.item_radius)
        self.cup_extra_m = max(self.settings.cup_diameter_m - CUP_DIAMETER_M, 0.0) / 2.0
        last = self.robot_cells[-1]
        self.window = last.window
        """The last robot's window: items past it are out of every robot's reach."""
        self._camera = None

    @property
    def robots(self) -> int:
        """Robots of the line."""
        return len(self.robot_cells)

    def reset(self, belt_speed: float) -> None:
        """Park every item, every robot to its `home`, belt at `belt_speed` [m/s], clock 0."""
        for slot in self.pool.active_slots():
            self.pool.park(self.data, int(slot))
        mujoco.mj_resetDataKeyframe(self.model, self.data, self._home_key)
        self.data.eq_active[:] = self.model.eq_active0
        self.belt.set_speed(belt_speed)
        for robot in self.robot_cells:
            robot.executor.set_payload(0.0)
        mujoco.mj_forward(self.model, self.data)

    belt_camera = Cell.belt_camera
    """The belt camera's renderer at a size, created once and kept (as the single cell's)."""

    def tcp(self) -> np.ndarray:
        """The first robot's cup lip centre now [m]."""
        return self.robot_cells[0].tcp()
