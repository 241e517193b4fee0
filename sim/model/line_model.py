"""A sorting line: one to four IRB 360s in series over one belt, assembled with `MjSpec`.

`compile_line(layout)` starts from the cell's scene (`models/cell/scene.xml`: belt, camera,
markers, lights, item pool, and the robot, its cage and its bins) and gives every robot of a
`layout` (a `LineLayout`) of several robots its own copy of them, `x` metres down the belt:

- the robot: `models/abb_irb360/irb360.xml` attached whole (`MjSpec.attach` on a frame at
  (x, 0, 0)) with the robot's name prefix on every element, so robot "r1_" has `r1_base_link`,
  `r1_motor_1_joint`, `r1_cup_site`, the actuators `r1_motor_1` .. `r1_axis4`, the six loop
  closures `r1_loop_1a` .. `r1_loop_3b` and the keyframe `r1_home`. The robot's own 1 ms step
  and implicitfast integrator are the scene's (which includes the same file), unchanged;
- its cage (the scene's `cage_*` geoms, drawn only) as `r1_cage_*`, and its bins, one per
  material (the file's thesis bins or a catalogue's, `sim.model.bin_layout`) as
  `r1_bin_<material>` with `r1_bin_<material>_floor_plate`, `r1_bin_<material>_drop`, ...;
- its cup's weld of every pool slot, `r1_item_<n>_grip` from `r1_cup_link` to `item_<n>`
  (inactive, as the pool file's `item_<n>_grip`), for `sim.cell.suction.SuctionCup(...,
  prefix="r1_")`.

The scene's own robot, cage, bins and welds are removed, so a line's every robot-related name
is prefixed. The keyframe `home` holds every robot at its home pose (the items parked); a
robot's `<prefix>home` holds that robot at home and the rest at `qpos0` (`reset_robot_home`
puts one robot back without touching the others). The belt keeps its infeed end and runs to
1.5 m past the last robot, as the scene's runs 1.5 m past its robot (longer when `settings`
ask so; a lone robot at x = 0 has the settings' belt, 4 m and up); the camera stays where it
is, 1.48 m or more upstream of the first robot.

Robots are kept apart by their cages: each stands in its own, 1.8 m long, so neighbours are at
least 1.8 m apart; their working circles (1.13 m across) and bins (within 0.42 m of the robot
along the belt) never overlap, so no robot can touch another or another's bins.

A camera per robot (`LineLayout(cameras_per_robot=True)`, the episode config's `[camera]
per_robot`): the first robot keeps the scene's `belt_camera`; every other robot k gets its own
belt camera `rk_belt_camera` on its camera line `camera_lines_m[k]`, with its LED box
(`rk_camera_box_*`), its marker shelves (`rk_marker_shelf_left`, `rk_marker_shelf_right`) and its
four corner markers (`rk_marker_0` .. `rk_marker_3`, the scene's colours in the scene's order),
by which its pipeline finds the belt as the first camera's does. The camera hangs where the
first one hangs ahead of the first robot, 1.48 m upstream of its robot, when that lies at least
half-way from the robot upstream; else half-way between the two robots (0.9 m upstream of its
robot at the default spacing of 1.8 m: on the line of the two cages' shared posts, 0.31 m
upstream of its robot's reach and 0.28 m downstream of the robot upstream's). Its rig is the
scene's shortened along the belt (`CAMERA_RIG_SCALE_X`): box and markers at +-0.2 m of the
camera line instead of +-0.32 m, so that the box clears the arms and rods of both robots over
their whole reach and neither robot nor an item it carries comes between the camera and a
marker (`tests/test_line_model.py`). Without it (the default) a line has the one camera.

A lone robot is compiled one way wherever it stands and whatever its pool: the scene edited in
place (`LineLayout(1, (x,))`, prefix "": the scene file's names), its robot, cage, bins and home
pose moved `x` down the belt, its belt at least 1.5 m past it when `x` > 0. At x = 0 with the
scene's pool it compiles to the scene file's cell to the byte. Only a line of several robots
is assembled by attaching (prefixes "r0_", "r1_", ...). Every per-robot function of the cell
takes the prefix (`sim.cell.robot`, `sim.cell.executor`, `sim.cell.suction`,
`sim.monitors.energy`, `sim.episode.pick_control`).
"""

from __future__ import annotations

import re
import tempfile
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import mujoco
import numpy as np

from perception.codes import THESIS_MATERIALS
from sim.checks import is_finite_number, is_integer
from sim.config.plant import (
    DISCHARGE_PAST_LAST_M,
    MAX_LAST_X_M,
    MAX_ROBOTS,
    MIN_SPACING_M,
    CellSettings,
)
from sim.errors import InvalidInput
from sim.flow.config import BELT_X_RANGE, X_CAMERA
from sim.model.scene_edits import set_belt_length, set_cup_diameter
from sim.paths import ROBOT_XML, SCENE_XML

CAGE_GEOMS = (
    *(f"cage_post_{e}_{s}" for e in ("upstream", "downstream") for s in ("left", "right")),
    *(f"cage_beam_{s}" for s in ("left", "right", "upstream", "downstream")),
    "cage_cross_upstream",
    "cage_cross_downstream",
    "cage_mount_plate",
)
"""The scene's cage around its robot (drawn only), copied for each robot of a line."""
SCENE_CAMERA = "belt_camera"
"""The scene's belt camera: the first robot's (and a line's only one without cameras per robot)."""
CAMERA_BOX_GEOMS = tuple(
    f"camera_box_{part}"
    for part in ("top", "upstream", "downstream", "left", "right", "post_left", "post_right")
)
"""The scene's LED box around its camera (drawn only), copied for each other robot's camera."""
MARKER_GEOMS = ("marker_shelf_left", "marker_shelf_right", *(f"marker_{i}" for i in range(4)))
"""The scene's corner markers (the pipeline locates the belt by them) and their shelves."""
FIRST_CAMERA_OFFSET_M = -X_CAMERA
"""How far the scene's camera hangs upstream of the scene's robot [m] (1.48)."""
CAMERA_RIG_SCALE_X = 0.625
"""Along the belt, another robot's camera rig is the scene's scaled by this: its box and its
markers at +-0.2 m of the camera line (the scene's at +-0.32 m), their shelves +-0.28 m long;
thicknesses and everything across the belt and in height as the scene's."""
ROBOT_ROOTS = ("base_link", "platform_link")
"""The robot's top bodies (base with the arms and rods; the free platform with the cup)."""
_PREFIX = re.compile(r"[A-Za-z][A-Za-z0-9]*_")


@dataclass(frozen=True)
class LineLayout:
    """How many robots a line has, where they stand and what their names start with.

    Attributes:
        robots: Number of robots, 1 to 4.
        positions_m: x of each robot's base centre along the belt, downstream in order [m]; the
            first at x >= 0 (the camera, at -1.48 m, stays upstream of it), each at least
            `MIN_SPACING_M` past the one before, the last at most `MAX_LAST_X_M`. Default:
            0, 1.8, 3.6, ... m.
        prefixes: Name prefix of each robot's elements. A lone robot's is "" (the scene's
            names, wherever it stands); several robots' are each a letter, letters or digits
            and "_", distinct. Default: ("",) for one robot, else "r0_", "r1_", ....
        cameras_per_robot: Whether every robot after the first has its own belt camera
            upstream of it (`camera_lines_m`; module docstring); False: the scene's one camera.
    """

    robots: int = 1
    positions_m: tuple[float, ...] = ()
    prefixes: tuple[str, ...] = ()
    cameras_per_robot: bool = False

    def __post_init__(self) -> None:
        n = self.robots
        if not (is_integer(n) and 1 <= n <= MAX_ROBOTS):
            raise InvalidInput("line.robots", f"1..{MAX_ROBOTS}", n)
        positions = self.positions_m or tuple(k * MIN_SPACING_M for k in range(n))
        allowed = (
            f"{n} x positions [m] in downstream order: the first >= 0, each >= {MIN_SPACING_M} m"
            f" past the one before, the last <= {MAX_LAST_X_M}"
        )
        if (
            not isinstance(positions, tuple | list)
            or len(positions) != n
            or not all(is_finite_number(x) for x in positions)
            or positions[0] < 0.0
            or positions[-1] > MAX_LAST_X_M
            or any(positions[k + 1] - positions[k] < MIN_SPACING_M - 1e-9 for k in range(n - 1))
        ):
            raise InvalidInput("line.positions_m", allowed, self.positions_m)
        object.__setattr__(self, "positions_m", tuple(float(x) for x in positions))
        prefixes = self.prefixes or (("",) if n == 1 else tuple(f"r{k}_" for k in range(n)))
        if (
            not isinstance(prefixes, tuple | list)
            or len(prefixes) != n
            or not all(isinstance(p, str) for p in prefixes)
            or len(set(prefixes)) != n
            or not all((p == "") if n == 1 else _PREFIX.fullmatch(p) for p in prefixes)
        ):
            allowed = "('',) for one robot" if n == 1 else f"{n} distinct prefixes like 'r0_'"
            raise InvalidInput("line.prefixes", allowed, self.prefixes)
        object.__setattr__(self, "prefixes", tuple(prefixes))
        if not isinstance(self.cameras_per_robot, bool):
            raise InvalidInput("line.cameras_per_robot", "true | false", self.cameras_per_robot)

    @property
    def camera_lines_m(self) -> tuple[float, ...]:
        """x of each robot's camera line [m], upstream first: the scene's camera's (-1.48 m)
        for the first robot; for robot k > 0 with `cameras_per_robot`, 1.48 m upstream of it or
        half-way from the robot upstream, whichever is nearer to it. Only the first without
        cameras per robot."""
        lines = [X_CAMERA]
        if self.cameras_per_robot:
            x = self.positions_m
            for k in range(1, self.robots):
                lines.append(x[k] - min(FIRST_CAMERA_OFFSET_M, 0.5 * (x[k] - x[k - 1])))
        return tuple(lines)

    @property
    def camera_prefixes(self) -> tuple[str, ...]:
        """Name prefix of each camera's elements, upstream first ("" for the scene's)."""
        return ("", *self.prefixes[1 : len(self.camera_lines_m)])

    @property
    def belt_length_m(self) -> float:
        """Length of belt the line needs: infeed to 1.5 m past the last robot [m]."""
        return self.positions_m[-1] + DISCHARGE_PAST_LAST_M - BELT_X_RANGE[0]

    @property
    def in_place(self) -> bool:
        """Whether the line is the scene's own robot edited in place: a lone robot."""
        return self.robots == 1


def line_elements(layout: LineLayout, materials=None) -> tuple:
    """The named elements the code reads in a line's model (`sim.model.mjcf.require_elements`):
    every robot's and its bins' (prefixed), the belt's, camera's, markers' and pool's."""
    from sim.model.bin_layout import bin_elements
    from sim.model.mjcf import ROBOT_ELEMENTS, cell_elements, robot_elements

    materials = THESIS_MATERIALS if materials is None else materials
    own = set(ROBOT_ELEMENTS) | set(bin_elements(materials))
    shared = tuple(e for e in cell_elements(materials) if e not in own)
    robots = tuple(
        e for p in layout.prefixes for e in (*robot_elements(p), *bin_elements(materials, p))
    )
    cameras = tuple(
        e
        for p in layout.camera_prefixes[1:]
        for e in ((("camera",), p + SCENE_CAMERA), *((("geom",), p + m) for m in MARKER_GEOMS))
    )
    return (*robots, *cameras, *shared, (("key",), "home"))


@lru_cache(maxsize=1)
def _robot_names() -> tuple[tuple[str, ...], tuple[str, ...], int]:
    """The robot file's joint and actuator names and its platform's qpos address."""
    from sim.model.mjcf import load_robot

    robot = load_robot()
    joints = tuple(robot.joint(j).name for j in range(robot.njnt))
    actuators = tuple(robot.actuator(a).name for a in range(robot.nu))
    return joints, actuators, int(robot.joint("platform_joint").qposadr[0])


def robot_qpos_index(model: mujoco.MjModel, prefix: str = "") -> np.ndarray:
    """Indices into `qpos` of the robot `prefix`'s joints (the robot file's, in its order)."""
    widths = {mujoco.mjtJoint.mjJNT_FREE: 7, mujoco.mjtJoint.mjJNT_BALL: 4}
    out: list[int] = []
    for name in _robot_names()[0]:
        joint = model.joint(prefix + name)
        start = int(joint.qposadr[0])
        out.extend(range(start, start + widths.get(int(joint.type[0]), 1)))
    return np.array(out)


def robot_dof_index(model: mujoco.MjModel, prefix: str = "") -> np.ndarray:
    """Indices into `qvel` of the robot `prefix`'s degrees of freedom."""
    widths = {mujoco.mjtJoint.mjJNT_FREE: 6, mujoco.mjtJoint.mjJNT_BALL: 3}
    out: list[int] = []
    for name in _robot_names()[0]:
        joint = model.joint(prefix + name)
        start = int(joint.dofadr[0])
        out.extend(range(start, start + widths.get(int(joint.type[0]), 1)))
    return np.array(out)


def robot_ctrl_index(model: mujoco.MjModel, prefix: str = "") -> np.ndarray:
    """Indices into `ctrl` of the robot `prefix`'s actuators (motors 1-3, axis 4)."""
    return np.array([model.actuator(prefix + name).id for name in _robot_names()[1]])


def reset_robot_home(model: mujoco.MjModel, data: mujoco.MjData, prefix: str = "") -> None:
    """Robot `prefix` back to its keyframe `<prefix>home` (joints, zero speeds, servo targets);
    the other robots and the items keep their state. Runs `mj_forward`."""
    key = model.key(f"{prefix}home")
    qpos, dofs, ctrl = (
        robot_qpos_index(model, prefix),
        robot_dof_index(model, prefix),
        robot_ctrl_index(model, prefix),
    )
    data.qpos[qpos] = key.qpos[qpos]
    data.qvel[dofs] = 0.0
    data.ctrl[ctrl] = key.ctrl[ctrl]
    mujoco.mj_forward(model, data)


def _move_in_place(spec: mujoco.MjSpec, x: float, materials) -> None:
    """The scene's own robot, its cage and bins `x` [m] down the belt (nothing at x = 0)."""
    if x == 0.0:
        return
    for name in ROBOT_ROOTS:
        spec.body(name).pos[0] += x
    key = spec.key("home")
    qpos = np.array(key.qpos)
    qpos[_robot_names()[2]] += x  # the free platform's x: world coordinates
    key.qpos = qpos
    for name in CAGE_GEOMS:
        spec.geom(name).pos[0] += x
    for name in materials.names:
        spec.body(f"bin_{name}").pos[0] += x


def _grip_template(spec: mujoco.MjSpec) -> tuple[list[str], dict]:
    """The pool's slots (their bodies, by the welds `item_<n>_grip`) and the welds' settings."""
    bodies: list[str] = []
    first = spec.equality("item_0_grip")
    while (weld := spec.equality(f"item_{len(bodies)}_grip")) is not None:
        bodies.append(weld.name2)
    settings = {
        "type": first.type,
        "objtype": first.objtype,
        "active": False,
        "solref": list(first.solref),
        "solimp": list(first.solimp),
        "data": list(first.data),
    }
    return bodies, settings


def _add_robot(spec, prefix: str, x: float, cup_diameter_m: float, materials, grips) -> None:
    """Robot `prefix` at `x` [m]: attached from its file, with its cage, bins and welds."""
    from sim.model.mjcf import ROBOT_ELEMENTS, load_spec

    robot = load_spec(ROBOT_XML, ROBOT_ELEMENTS)
    key = robot.key("home")
    qpos = np.array(key.qpos)
    qpos[_robot_names()[2]] += x  # the key's free platform is in world coordinates
    key.qpos = qpos
    frame = spec.worldbody.add_frame(pos=[x, 0.0, 0.0])
    spec.attach(robot, prefix=prefix, frame=frame)
    set_cup_diameter(spec, cup_diameter_m, prefix=prefix)
    for name in CAGE_GEOMS:
        cage = spec.geom(name)
        spec.worldbody.add_geom(
            cage.classname,
            name=prefix + name,
            type=cage.type,
            size=cage.size.copy(),
            pos=cage.pos + np.array([x, 0.0, 0.0]),
            material=cage.material,
        )
    for name in materials.names:  # copies (the spec copies during attach), not moves
        frame.attach_body(spec.body(f"bin_{name}"), prefix, "")
    bodies, settings = grips
    for slot, body in enumerate(bodies):
        spec.add_equality(
            name=f"{prefix}item_{slot}_grip", name1=f"{prefix}cup_link", name2=body, **settings
        )


def _add_camera(spec: mujoco.MjSpec, prefix: str, x_line: float) -> None:
    """A copy of the scene's belt camera, its box, shelves and markers on the camera line
    `x_line` [m], names prefixed with `prefix`, the rig shortened along the belt by
    `CAMERA_RIG_SCALE_X` (lengths over 5 cm and offsets from the camera)."""
    scene = spec.camera(SCENE_CAMERA)
    x0 = float(scene.pos[0])
    for name in (*CAMERA_BOX_GEOMS, *MARKER_GEOMS):
        geom = spec.geom(name)
        size, pos = geom.size.copy(), geom.pos.copy()
        if size[0] > 0.05:  # a length along the belt, not a wall's or a marker's thickness
            size[0] *= CAMERA_RIG_SCALE_X
        pos[0] = x_line + CAMERA_RIG_SCALE_X * (pos[0] - x0)
        spec.worldbody.add_geom(
            geom.classname,
            name=prefix + name,
            type=geom.type,
            size=size,
            pos=pos,
            material=geom.material,
            rgba=geom.rgba.copy(),
        )
    camera = spec.worldbody.add_camera(
        name=prefix + SCENE_CAMERA,
        pos=[x_line, float(scene.pos[1]), float(scene.pos[2])],
        fovy=scene.fovy,
        resolution=scene.resolution.copy(),
    )
    camera.alt.type = scene.alt.type
    camera.alt.xyaxes = scene.alt.xyaxes.copy()
    camera.quat = scene.quat.copy()


LINE_POOL_SIZE = 160
"""Item bodies of a line of several robots: a line exists to serve belts one robot cannot clear
(`sim.flow.limits.LINE_MAX_ITEMS_PER_METRE`)."""


def _belt_length_m(layout: LineLayout, settings: CellSettings) -> float:
    """The belt's length [m]: the settings' for the scene's robot at x = 0 (their range is the
    scene's, 4 m and up), at least `layout.belt_length_m` once a robot stands further down."""
    if layout.positions_m[-1] == 0.0:
        return settings.belt_length_m
    return max(settings.belt_length_m, layout.belt_length_m)


def _scene_with_pool(pool_size: int, folder: Path) -> Path:
    """A copy of the cell's scene in `folder` whose pool has `pool_size` item bodies (the
    scene's `items.xml` generated again at that size, `sim.model.item_pool_xml`)."""
    from sim.flow.catalogue import load_catalogue
    from sim.model.item_pool_xml import pool_xml

    (folder / "cell").mkdir()
    (folder / "abb_irb360").mkdir()
    (folder / "cell" / "scene.xml").write_bytes(SCENE_XML.read_bytes())
    (folder / "abb_irb360" / "irb360.xml").write_bytes(ROBOT_XML.read_bytes())
    (folder / "cell" / "items.xml").write_text(pool_xml(load_catalogue(), pool_size))
    return folder / "cell" / "scene.xml"


def line_spec(
    layout: LineLayout,
    settings: CellSettings | None = None,
    materials=None,
    path=SCENE_XML,
    pool_size: int | None = None,
) -> mujoco.MjSpec:
    """The line's `MjSpec` (see the module docstring), not yet holding the keyframe `home` of a
    line of several robots (`compile_line` adds it, from the compiled robots' keys).

    Args:
        layout: The robots, their positions and prefixes.
        settings: Cup diameter, belt length and width (`sim.model.scene_edits`); the belt is
            made at least `layout.belt_length_m` long when a robot stands past x = 0.
        materials: One bin per material for each robot (`perception.codes.Materials`); the
            thesis's when None.
        path: The scene file.
        pool_size: Item bodies in the pool (the scene's file: `sim.model.item_pool_xml`);
            the scene's own for one robot in place, `LINE_POOL_SIZE` for a line, when None.

    Raises:
        ModelFileError: the scene or the robot's file is refused (`sim.model.mjcf`).
    """
    from sim.model.belt_width import set_belt_width
    from sim.model.bin_layout import lay_out_bins
    from sim.model.mjcf import CELL_ELEMENTS, load_spec

    settings = settings or CellSettings()
    materials = THESIS_MATERIALS if materials is None else materials
    if pool_size is None and not layout.in_place:
        pool_size = LINE_POOL_SIZE
    if pool_size is None or path != SCENE_XML:
        spec = load_spec(path, CELL_ELEMENTS)
    else:  # the scene with a pool of `pool_size` bodies
        with tempfile.TemporaryDirectory() as folder:
            spec = load_spec(_scene_with_pool(pool_size, Path(folder)), CELL_ELEMENTS)
    set_belt_length(spec, _belt_length_m(layout, settings))
    lay_out_bins(spec, materials)  # the file's own bins for the thesis's materials
    set_belt_width(spec, settings.belt_width_m, materials)  # before robots copy cage and bins
    if layout.in_place:
        set_cup_diameter(spec, settings.cup_diameter_m)
        _move_in_place(spec, layout.positions_m[0], materials)
        return spec
    grips = _grip_template(spec)
    for name in ROBOT_ROOTS:  # takes its loop closures, actuators and the pool's welds along
        spec.delete(spec.body(name))
    spec.delete(spec.key("home"))
    spec.copy_during_attach = True
    for prefix, x in zip(layout.prefixes, layout.positions_m, strict=True):
        _add_robot(spec, prefix, x, settings.cup_diameter_m, materials, grips)
    for name in CAGE_GEOMS:
        spec.delete(spec.geom(name))
    for name in materials.names:
        spec.delete(spec.body(f"bin_{name}"))
    for prefix, x_line in zip(layout.camera_prefixes[1:], layout.camera_lines_m[1:], strict=True):
        _add_camera(spec, prefix, x_line)
    return spec


def _line_home(model: mujoco.MjModel, layout: LineLayout) -> tuple[np.ndarray, np.ndarray]:
    """(qpos, ctrl) of every robot at its own home, the items parked (`qpos0`)."""
    qpos, ctrl = model.qpos0.copy(), np.zeros(model.nu)
    for prefix in layout.prefixes:
        key = model.key(f"{prefix}home")
        index, actuators = robot_qpos_index(model, prefix), robot_ctrl_index(model, prefix)
        qpos[index], ctrl[actuators] = key.qpos[index], key.ctrl[actuators]
    return qpos, ctrl


def compile_line(
    layout: LineLayout | None = None,
    settings: CellSettings | None = None,
    materials=None,
    path=SCENE_XML,
    pool_size: int | None = None,
) -> mujoco.MjModel:
    """The line's compiled model (arguments as `line_spec`; `LineLayout()` when None: the
    single cell), checked as `sim.model.mjcf` checks a file, every robot's elements present.

    Raises:
        ModelFileError: a file is refused or the model lacks an element the code needs.
    """
    from sim.model.mjcf import compile_spec

    layout = layout or LineLayout()
    spec = line_spec(layout, settings, materials, path, pool_size)
    elements = line_elements(layout, materials)
    if layout.in_place:
        return compile_spec(spec, path, elements)
    qpos, ctrl = _line_home(compile_spec(spec, path), layout)
    spec.add_key(name="home", qpos=qpos.tolist(), ctrl=ctrl.tolist())
    return compile_spec(spec, path, elements)


def pool_capacity(line: bool) -> int:
    """Item bodies the pool of a cell (`line` False) or of a line has when not sized for one
    flow: the most items any flow it takes may have on the belt at once."""
    from sim.model.item_pool_xml import POOL_SIZE

    return LINE_POOL_SIZE if line else POOL_SIZE
