"""The compiled sorting cell and the long-lived objects built on it, reused between episodes.

A `Cell` owns one MjModel/MjData (the item pool switches geom fields of its own model at run
time, so a cell is never shared between simulations running at once), the belt, the item pool
and its robots: one to four IRB 360s over the one belt, each a `sim.cell.robots.RobotView` (a
single robot is a line of one). Items are read through `Cell.items` (`sim.cell.items`), whose
accessors keep riders' poses right. `reset` parks every item and puts every robot back to its
`home` keyframe, so a sweep worker or a Ray actor runs many episodes on one compiled model.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco

from planner.motion.kinematics import reachable_mask
from planner.motion.reach_window import ReachWindow
from sim.cell.conveyor import Belt
from sim.cell.item_pool import ItemPool
from sim.cell.items import Items
from sim.cell.riding import wake_line
from sim.cell.robots import DESIGN_PAYLOAD_KG, PICK_Z_NOMINAL, RobotView
from sim.config.plant import CUP_DIAMETER_M, CellSettings
from sim.errors import InvalidInput
from sim.flow.catalogue import Catalogue, load_catalogue
from sim.model.line_model import LineLayout, compile_line

if TYPE_CHECKING:
    from sim.cell.camera import SceneRenderer

__all__ = ["DESIGN_PAYLOAD_KG", "PICK_Z_NOMINAL", "Cell"]


class Cell:
    """The compiled cell (model, data), its belt, item pool and robots.

    Args:
        model: A compiled cell (`sim.model.line_model.compile_line`); the lone robot at
            x = 0, `models/cell/scene.xml` compiled with `settings` and one bin per material of
            `catalogue`, when omitted.
        settings: The cup's diameter and the belt's length (`sim.model.scene_edits`): what
            `model` is compiled with, or was compiled with when given; the scene's own when
            None.
        catalogue: The item catalogue (its materials name the bins); the default one
            (`sim/data/items.toml`, the thesis's paper, plastic and aluminium) when omitted.
        prefixes: The robots' name prefixes in the model, upstream first (`LineLayout`'s):
            ("",), a lone robot's, when omitted.
        pool_capacity: The items on the belt at once that the flows it takes are refused
            beyond (`sim.episode.builder.episode_flow`); its pool's size when omitted.
    """

    def __init__(
        self,
        model: mujoco.MjModel | None = None,
        settings: CellSettings | None = None,
        catalogue: Catalogue | None = None,
        prefixes: tuple[str, ...] = ("",),
        pool_capacity: int | None = None,
    ):
        if not prefixes:
            raise InvalidInput("prefixes", "at least one robot's prefix", prefixes)
        self.catalogue = catalogue if catalogue is not None else load_catalogue()
        self.materials = self.catalogue.materials
        self.settings = settings or CellSettings()
        """What the model was compiled with (cup, belt)."""
        self.model = (
            model
            if model is not None
            else compile_line(LineLayout(), self.settings, self.materials)
        )
        self.data = mujoco.MjData(self.model)
        self.belt = Belt(self.model)
        self.pool = ItemPool(self.model, self.catalogue, self.belt)
        self.pool_capacity = self.pool.size if pool_capacity is None else int(pool_capacity)
        """The most items any flow this cell takes may have on the belt at once (the pool's
        size, or more for a pool sized for one flow, `sim.cell.item_pool.pool_size_for`)."""
        self.items = Items(self.model, self.data, self.pool)
        """The items, read through accessors that keep riders' poses right."""
        self.robots = tuple(
            RobotView(self.model, self.data, k, p, self.materials) for k, p in enumerate(prefixes)
        )
        """The robots, upstream first."""
        self._home_key = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_KEY, "home")
        mujoco.mj_forward(self.model, self.data)
        self.item_radius = max(
            float(self.pool.props(k)["geom_rbound"]) for k in range(len(self.catalogue.types))
        )
        """Largest bounding radius of a catalogue type at its nominal size [m]."""
        first = self.robots[0]
        self.wake_x = wake_line(
            lambda p: reachable_mask(first.geometry, p), self.item_radius + self.cup_extra_m
        )
        """Settled items riding the belt wake before this x (`sim.cell.riding`) [m]; an episode
        whose largest item is larger than `item_radius` wakes them that much earlier, a cup
        larger than the scene's by its extra radius."""
        self._cameras: dict = {}  # belt camera name -> its renderer (sim.cell.camera)
        self._scene_renderer: SceneRenderer | None = (
            None  # the one every belt camera of the cell renders in
        )

    @property
    def window(self) -> ReachWindow:
        """The last robot's window: items past it are out of every robot's reach."""
        return self.robots[-1].window

    @property
    def cup_radius(self) -> float:
        """Radius of the cups' lips [m] (the model's; every robot of a cell has the same cup)."""
        return self.robots[0].cup_radius

    @property
    def cup_extra_m(self) -> float:
        """How much farther a larger cup than the scene's reaches around the TCP [m] (0 for the
        scene's cup or a smaller one): the distances that allow for the cup's radius (riders'
        wake line, where an unpicked item is out of reach) widen by it."""
        return max(self.cup_radius - 0.5 * CUP_DIAMETER_M, 0.0)

    def reset(self, belt_speed: float) -> None:
        """Park every item, every robot to `home`, belt at `belt_speed` [m/s], clock at 0.

        Args:
            belt_speed: The belt's speed [m/s].
        """
        self.items.ride(None)
        for slot in self.pool.active_slots():
            self.pool.park(self.data, int(slot))
        mujoco.mj_resetDataKeyframe(self.model, self.data, self._home_key)
        self.data.eq_active[:] = self.model.eq_active0
        self.belt.set_speed(belt_speed)
        for robot in self.robots:
            robot.executor.set_payload(0.0)
        mujoco.mj_forward(self.model, self.data)

    def belt_camera(self, size: tuple[int, int], name: str | None = None):
        """A belt camera's renderer at `size` [px] (the perception's multisampling), created
        once and kept for later episodes; every camera of the cell renders in one
        `sim.cell.camera.SceneRenderer` (one render context, one scene).

        Args:
            size: Frame size (width, height) [px].
            name: The MJCF camera (a line's robot's own, `sim.cell.camera.camera_name`); None:
                the scene's `belt_camera`.

        Returns:
            The `sim.cell.camera.BeltCamera`: one per camera name and cell.
        """
        from sim.cell.camera import CAMERA_NAME, PERCEPTION_SAMPLES, BeltCamera, SceneRenderer

        name = CAMERA_NAME if name is None else name
        camera = self._cameras.get(name)
        if camera is None or camera.size != tuple(size):
            if self._scene_renderer is None:
                self._scene_renderer = SceneRenderer(self.model)
            self._cameras[name] = BeltCamera(
                self.model, *size, name=name, samples=PERCEPTION_SAMPLES,
                renderer=self._scene_renderer,
            )  # fmt: skip
        return self._cameras[name]
