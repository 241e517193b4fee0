"""The belt's width (`[belt] width_m`) written into the cell's `MjSpec`: what stands beside the
belt keeps its distance from the belt's edges.

The scene's belt (`models/cell/scene.xml`) is 0.8 m wide. `set_belt_width(spec, width_m,
materials)` makes it `width_m` wide and moves every element whose place follows the belt's
edges by the change of half the width, `dw` (outwards for a wider belt, inwards for a narrower
one):

- the belt (`belt`) and its frame (`belt_frame`) get wider; the side rails (`rail_left`,
  `rail_right`) and the legs (`belt_leg_*`) move out with the edges;
- the camera's rig: its LED box's side walls and posts (`camera_box_left`, `..._right`,
  `camera_box_post_*`) move out, its top and end walls get wider; the marker shelves and the
  four corner markers (`marker_shelf_*`, `marker_0` .. `marker_3`) move out, so the pipeline
  still finds the belt between them. The camera itself stays 0.75 m above the belt with its
  lens (`fovy` 60 deg, 16:9 and the calibration's distortion): its frame spans about 1.6 m
  across the belt at the belt's height, so the 1.2 m belt's markers (+-0.72 m) and items up
  to 0.25 m tall at its edges stay inside it (`tests/test_belt_width.py`);
- the robot's cage widens with a wider belt (posts and side beams out, cross beams longer;
  drawn only), never narrows;
- every bin (`bin_<material>`, the file's or a catalogue's, `sim.model.bin_layout`) moves out
  with the edge on its side. Its release point (`bin_<material>_drop`) moves with it while the
  robot still reaches it with `REACH_MARGIN_M` to spare. Beyond that (belts wider than about
  0.9 m: the IRB 360's working circle is 1.13 m across at the belt) it becomes the point of
  the bin's opening nearest the robot, at least `END_M` from its end walls and as far inside
  its inner wall as the robot reaches (8 cm down to 3 cm, `INSETS_M`), at the lowest height
  from the scene's up (in 1 cm steps, up to `RELEASE_Z_MAX_M`) where the robot reaches it with
  that margin, and the bin grows outwards to an opening at
  least `OPENING_M` across the belt (its inner wall stays): an item let go of so near the
  inner wall falls in, where across a narrower bin a long item lay bridging the rail and the
  bin's outer wall. A bin whose release point the robot reaches at no such height is refused
  in one line naming `belt.width_m`.

The item pool, the robot, the camera's pose and the belt's length are untouched. At the
scene's own width nothing is edited (a default cell is the file's, to the bit).
"""

from __future__ import annotations

import functools
import math

import mujoco
import numpy as np

from sim.errors import InvalidInput

BELT_RUN_WIDENED = ("belt", "belt_frame")
"""Belt geoms whose half size across the belt grows by `dw`."""
BELT_RUN_MOVED = ("rail_left", "rail_right")
"""Belt geoms that move out by `dw` (with the legs, `belt_leg_*`)."""
LEG_PREFIX = "belt_leg_"
CAMERA_RIG_WIDENED = ("camera_box_top", "camera_box_upstream", "camera_box_downstream")
CAMERA_RIG_MOVED = (
    "camera_box_left",
    "camera_box_right",
    "camera_box_post_left",
    "camera_box_post_right",
    "marker_shelf_left",
    "marker_shelf_right",
    *(f"marker_{i}" for i in range(4)),
)
CAGE_MOVED = (
    *(f"cage_post_{e}_{s}" for e in ("upstream", "downstream") for s in ("left", "right")),
    "cage_beam_left",
    "cage_beam_right",
)
CAGE_WIDENED = ("cage_beam_upstream", "cage_beam_downstream")
CAGE_CROSS = ("cage_cross_upstream", "cage_cross_downstream")
REACH_MARGIN_M = 0.01
"""How much farther from the belt than a release point the robot must still reach [m]."""
INSETS_M = (0.08, 0.07, 0.06, 0.05, 0.04, 0.03)
"""A moved release point's distances inside its bin's inner wall, tried in turn [m]."""
END_M = 0.15
"""A moved release point's least distance from its bin's end walls [m] (an A4 sheet's half
length, 0.15 m: nearer, items came to rest across an end wall)."""
RELEASE_Z_MAX_M = 0.35
"""Highest release point above the belt [m] (the top of the robot's working range)."""
RELEASE_Z_STEP_M = 0.01
OPENING_M = 0.42
"""Least opening across the belt of a bin whose release point moved to its inner wall [m]: an A4
sheet's diagonal (0.36 m) and more; narrower, items came to rest bridging the rail and the
bin's outer wall."""


def scene_half_width(spec: mujoco.MjSpec) -> float:
    """Half the width of the spec's belt (geom `belt`) [m]."""
    return float(spec.geom("belt").size[1])


def set_belt_width(spec: mujoco.MjSpec, width_m: float, materials) -> None:
    """The belt `width_m` [m] wide, what stands beside it moved with its edges and the release
    points of the bins of `materials` kept in the robot's reach (module docstring).

    Raises:
        InvalidInput: `belt.width_m`, when the robot reaches a bin's release point at no height.
    """
    dw = 0.5 * float(width_m) - scene_half_width(spec)
    if dw == 0.0:
        return
    legs = tuple(g.name for g in spec.geoms if g.name.startswith(LEG_PREFIX))
    for name in (*BELT_RUN_WIDENED, *CAMERA_RIG_WIDENED):
        spec.geom(name).size[1] += dw
    for name in (*BELT_RUN_MOVED, *legs, *CAMERA_RIG_MOVED):
        _move_out(spec.geom(name), dw)
    if dw > 0.0:
        for name in CAGE_MOVED:
            _move_out(spec.geom(name), dw)
        for name in (*CAGE_WIDENED, *CAGE_CROSS):
            spec.geom(name).size[1] += dw
    geometry = _robot_geometry()
    for name in materials.names:
        body = spec.body(f"bin_{name}")
        _move_out(body, dw)
        _place_release_point(spec, name, geometry, width_m)


def _move_out(element, dw: float) -> None:
    """Move a geom or body `dw` [m] away from the belt's centre line (y = 0)."""
    element.pos[1] += math.copysign(1.0, float(element.pos[1])) * dw


@functools.cache
def _robot_geometry():
    """The IRB 360's geometry at the origin (its file's), for the reach of release points."""
    from sim.model.mjcf import load_robot
    from sim.model.robot_geometry import geometry_from_model

    return geometry_from_model(load_robot())


def reaches(geometry, point, side: float) -> bool:
    """Whether the robot reaches `point` (x, y, z) [m] and the point `REACH_MARGIN_M` farther
    out on its `side` (+1: +y, -1: -y) of the belt."""
    from planner.motion.kinematics import reachable_mask

    p = np.asarray(point, dtype=float)
    farther = p + np.array([0.0, math.copysign(REACH_MARGIN_M, side), 0.0])
    return bool(reachable_mask(geometry, np.stack([p, farther])).all())


def _place_release_point(spec: mujoco.MjSpec, name: str, geometry, width_m: float) -> None:
    """Bin `name`'s release point where the robot reaches it (module docstring)."""
    body = spec.body(f"bin_{name}")
    site, plate = spec.site(f"bin_{name}_drop"), spec.geom(f"bin_{name}_floor_plate")
    origin = np.array(body.pos, dtype=float)
    side = math.copysign(1.0, origin[1])
    if reaches(geometry, origin + site.pos, side):
        return
    _widen(spec.body(f"bin_{name}"), plate, side)
    centre, half = origin + plate.pos, np.array(plate.size, dtype=float)
    span = max(half[0] - END_M, 0.0)  # a bin shorter than 2 END_M: its middle
    x = min(max(0.0, centre[0] - span), centre[0] + span)
    heights = np.arange(float(origin[2] + site.pos[2]), RELEASE_Z_MAX_M + 1e-9, RELEASE_Z_STEP_M)
    for inset in INSETS_M:
        y = side * (abs(centre[1]) - half[1] + inset)
        for z in heights:
            if reaches(geometry, (x, y, z), side):
                site.pos = np.array([x, y, z]) - origin
                return
    allowed = f"a belt whose bins the robot reaches (the {name} bin's release point is not)"
    raise InvalidInput("belt.width_m", allowed, width_m)


def _widen(body, plate, side: float) -> None:
    """Grow a bin outwards to an opening `OPENING_M` across the belt: its inner wall stays, its
    outer wall moves out by the growth, its floor, end walls and floor site get wider (and,
    with its stand, move out by half the growth)."""
    grow = max(0.0, OPENING_M - 2.0 * float(plate.size[1]))
    if grow == 0.0:
        return
    for element in (*body.geoms, *body.sites):
        if element.name.endswith("_wall_inner"):
            continue
        outer = element.name.endswith("_wall_outer")
        element.pos[1] += side * (grow if outer else 0.5 * grow)
        if element.name.endswith(("_floor_plate", "_wall_upstream", "_wall_downstream", "_floor")):
            element.size[1] += 0.5 * grow
