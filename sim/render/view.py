"""The video's view of the cell: a free camera over the belt, see-through geoms, projection.

The view looks from the paper bin's side, a little upstream, 45 degrees down, at the belt from
the camera box (x = -1.48 m) past the robot (for a line, to its last robot): the robot's base
(0.9 m above the belt) stands behind its pick zone, which the view sees from below the base's
level, items and cup in the open; the paper bin is in front of the belt, the plastic and
aluminium bins' rims show beyond it (their labels mark them).
The robot's cage and the camera box are drawn see-through (`ghosted_geoms`, `ghost`), and an
infinite floor is drawn as a large square that looks the same (`finite_floors`). `project`
turns world points into the pixels of a rendered view, for the labels drawn over a frame.
"""

from __future__ import annotations

import mujoco
import numpy as np

LOOKAT = (-0.45, 0.1, 0.0)
"""Point the single cell's view looks at [m]."""
DISTANCE = 3.0
"""The single cell's camera distance from `LOOKAT` [m]."""
AZIMUTH = 80.0
"""The camera's azimuth [deg] (90: from the paper bin's side, square to the belt). Until the
view was changed for the robot's base: 135, from downstream, 48 degrees down, where the base
hid the pick zone."""
ELEVATION = -45.0
"""The camera's elevation [deg]."""
GHOSTED_PREFIXES = ("cage_", "camera_box_")
"""Geoms drawn see-through in the video (the robot's cage and the camera's box would hide the
belt and the robot), by name prefix in the MJCF."""
GHOST_ALPHA = 0.12
"""Opacity of a see-through geom (0: invisible, 1: solid)."""
FLOOR_HALF_SIZE_M = 10.0
"""The video draws an infinite textured floor as a square of this half size with the same
texture scale: the same pixels (the view sees the floor within 6 m), fewer triangles."""


def last_robot_x(model: mujoco.MjModel | None) -> float:
    """x of the most downstream robot's base [m]: the largest x of a `*base_link` body of
    `model` (0 for the single cell or no model)."""
    if model is None:
        return 0.0
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    xs = [
        float(data.xpos[b][0])
        for b in range(model.nbody)
        if (model.body(b).name or "").endswith("base_link")
    ]
    return max(xs, default=0.0)


def view_camera(model: mujoco.MjModel | None = None) -> mujoco.MjvCamera:
    """A free camera framing the belt from the camera box to the robot and the bins.

    Args:
        model: The compiled cell; for a line, the view reaches to its last robot (farther back,
            centred on the line). None: the single cell's view.
    """
    span = last_robot_x(model)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = (LOOKAT[0] + 0.5 * span, LOOKAT[1], LOOKAT[2])
    cam.distance, cam.azimuth, cam.elevation = DISTANCE + 0.6 * span, AZIMUTH, ELEVATION
    return cam


def ghosted_geoms(model: mujoco.MjModel) -> frozenset[int]:
    """Ids of the geoms the video draws see-through: those named with `GHOSTED_PREFIXES`,
    also after a line's robot prefix (`r1_cage_*`)."""
    return frozenset(
        i
        for i in range(model.ngeom)
        if (name := model.geom(i).name).startswith(GHOSTED_PREFIXES)
        or name.partition("_")[2].startswith(GHOSTED_PREFIXES)
    )


def ghost(scene: mujoco.MjvScene, geom_ids: frozenset[int], alpha: float = GHOST_ALPHA) -> None:
    """Make the scene's copies of `geom_ids` (`ghosted_geoms`) see-through, of opacity
    `alpha` (0..1); call after `update_scene`."""
    for k in range(scene.ngeom):
        g = scene.geoms[k]
        if g.objtype == mujoco.mjtObj.mjOBJ_GEOM and g.objid in geom_ids:
            g.rgba[3] = alpha


def project(scene: mujoco.MjvScene, points: np.ndarray, size) -> np.ndarray:
    """Pixel coordinates of world points in the scene's rendered view.

    Args:
        scene: The scene as last rendered (its first GL camera is used).
        points: World points (N, 3) [m].
        size: The frame's (width, height) [px].

    Returns:
        (N, 2) pixel coordinates [px]; NaN for points behind the camera.
    """
    width, height = size
    gl = scene.camera[0]
    forward, up = np.array(gl.forward), np.array(gl.up)
    right = np.cross(forward, up)
    rel = np.asarray(points, dtype=float) - np.array(gl.pos)
    depth = rel @ forward
    focal = 0.5 * height * gl.frustum_near / gl.frustum_top
    with np.errstate(divide="ignore", invalid="ignore"):
        u = width / 2.0 + focal * (rel @ right) / depth
        v = height / 2.0 - focal * (rel @ up) / depth
    uv = np.column_stack([u, v])
    uv[depth <= 1e-6] = np.nan
    return uv


def finite_floors(model: mujoco.MjModel, half_size: float = FLOOR_HALF_SIZE_M) -> list[int]:
    """Turn the infinite planes of a model the video draws into squares of half size
    `half_size` [m] that look the same.

    An infinite plane's texture repeats `texrepeat` times over 2 m, a finite one's over its side
    (unless `texuniform`). Only planes with a material of their own (or none) are changed. For
    drawing only: this changes the model.

    Returns:
        The ids of the planes changed.
    """
    planes = np.flatnonzero(
        (model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE)
        & ((model.geom_size[:, 0] <= 0) | (model.geom_size[:, 1] <= 0))
    )
    changed = []
    for geom in planes:
        mat = model.geom_matid[geom]
        if mat >= 0 and np.count_nonzero(model.geom_matid == mat) > 1:
            continue
        if mat >= 0 and not model.mat_texuniform[mat]:
            model.mat_texrepeat[mat] *= half_size
        model.geom_size[geom] = (half_size, half_size, half_size / 2.0)
        changed.append(int(geom))
    return changed
