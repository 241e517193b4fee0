"""The compiled sorting cell and the long-lived objects built on it, reused between episodes.

A `Cell` owns one MjModel/MjData (the item pool switches geom fields of its own model at run
time, so a cell is never shared between simulations running at once), the belt, the item pool,
the robot's geometry, trajectory generator and executor, the reachable window and the bins'
release points. `reset` parks every item and puts the robot back to its `home` keyframe, so a
sweep worker or a Ray actor runs many episodes on one compiled model.
"""

from __future__ import annotations

import mujoco
import numpy as np

from planner.motion.kinematics import reachable_mask
from planner.motion.limits import limits_for_payload
from planner.motion.reach_window import ReachWindow
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from sim.cell.conveyor import Belt
from sim.cell.executor import TrajectoryExecutor, lumped_dynamics
from sim.cell.item_pool import ItemPool
from sim.cell.riding import wake_line
from sim.cell.robot import geometry_from_model, tcp_position
from sim.flow.catalogue import Catalogue, load_catalogue
from sim.model.scene_edits import CUP_DIAMETER_M, CellSettings, compile_scene

PICK_Z_NOMINAL = 0.02
"""TCP height of the reachable window the planners use (a typical item top) [m]."""
DESIGN_PAYLOAD_KG = 1.0
"""Payload the pick trajectories are planned for: the heaviest catalogue item is well under it."""


class Cell:
    """The compiled cell (model, data) and its robot, belt, pool and bins.

    Args:
        model: A compiled cell; `models/cell/scene.xml` compiled with `settings` and one bin
            per material of `catalogue` when omitted.
        settings: The cup's diameter and the belt's length (`sim.model.scene_edits`); the
            scene's own when None. Only with `model` omitted.
        catalogue: The item catalogue (its materials name the bins); the default one
            (`sim/data/items.toml`, the thesis's paper, plastic and aluminium) when omitted.
    """

    def __init__(
        self,
        model: mujoco.MjModel | None = None,
        settings: CellSettings | None = None,
        catalogue: Catalogue | None = None,
    ):
        if model is not None and settings is not None:
            raise ValueError("Cell takes a compiled model or the settings to compile, not both")
        self.catalogue = catalogue if catalogue is not None else load_catalogue()
        self.materials = self.catalogue.materials
        self.settings = settings or CellSettings()
        """What the model was compiled with (a given `model`: the defaults, as far as known)."""
        self.model = (
            model if model is not None else compile_scene(self.settings, materials=self.materials)
        )
        self.data = mujoco.MjData(self.model)
        self.belt = Belt(self.model)
        self.pool = ItemPool(self.model, self.catalogue, self.belt)
        self.geometry = geometry_from_model(self.model)
        self.limits = limits_for_payload(DESIGN_PAYLOAD_KG)
        dynamics = lumped_dynamics(self.model, self.geometry, DESIGN_PAYLOAD_KG)
        self.generator = RuckigTrajectoryGenerator(self.limits, self.geometry, dynamics)
        self.executor = TrajectoryExecutor(self.model, self.data, geometry=self.geometry)
        self.window = ReachWindow.from_reachable(
            lambda p: reachable_mask(self.geometry, p), PICK_Z_NOMINAL
        )
        mujoco.mj_forward(self.model, self.data)
        self.drop_xyz = {
            c: self.data.site(f"bin_{name}_drop").xpos.copy()
            for c, name in zip(self.materials.ids, self.materials.names, strict=True)
        }
        self._home_key = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_KEY, "home")
        self.item_radius = max(
            float(self.pool.props(k)["geom_rbound"]) for k in range(len(self.catalogue.types))
        )
        """Largest bounding radius of a catalogue type at its nominal size [m]."""
        self.cup_radius = float(self.model.geom("cup_collision").size[0])
        """Radius of the cup's lip [m] (the model's)."""
        self.wake_x = wake_line(
            lambda p: reachable_mask(self.geometry, p), self.item_radius + self.cup_extra_m
        )
        """Settled items riding the belt wake before this x (`sim.cell.riding`) [m]; an episode
        whose largest item is larger than `item_radius` wakes them that much earlier, a cup
        larger than the scene's by its extra radius."""

    @property
    def cup_extra_m(self) -> float:
        """How much farther a larger cup than the scene's reaches around the TCP [m] (0 for the
        scene's cup or a smaller one): the distances that allow for the cup's radius (riders'
        wake line, where an unpicked item is out of reach) widen by it."""
        return max(self.cup_radius - 0.5 * CUP_DIAMETER_M, 0.0)

    def bins_tuple(self) -> tuple[tuple[float, float, float], ...]:
        """Release points of the materials' bins, in material order, for the planners [m]."""
        return tuple(tuple(float(v) for v in self.drop_xyz[c]) for c in self.materials.ids)

    def reset(self, belt_speed: float) -> None:
        """Park every item, robot to `home`, belt at `belt_speed` [m/s], clock at 0."""
        for slot in self.pool.active_slots():
            self.pool.park(self.data, int(slot))
        mujoco.mj_resetDataKeyframe(self.model, self.data, self._home_key)
        self.data.eq_active[:] = self.model.eq_active0
        self.belt.set_speed(belt_speed)
        self.executor.set_payload(0.0)
        mujoco.mj_forward(self.model, self.data)

    def belt_camera(self, size: tuple[int, int]):
        """The belt camera's renderer at `size` (the perception's multisampling), created once
        and kept for later episodes."""
        from sim.cell.camera import PERCEPTION_SAMPLES, BeltCamera

        camera = getattr(self, "_camera", None)
        if camera is None or camera.size != tuple(size):
            if camera is not None:
                camera.close()  # one renderer (GL context) per cell
            self._camera = BeltCamera(self.model, *size, samples=PERCEPTION_SAMPLES)
        return self._camera

    def tcp(self) -> np.ndarray:
        """Cup lip centre now [m]."""
        return tcp_position(self.model, self.data)
