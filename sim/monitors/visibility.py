"""How much of each item the belt camera sees: the visible fraction of its top area.

At each camera observation, an item's visible fraction is the number of pixels of a
segmentation render of the belt camera that show it (`sim.render.segmentation`: its geom or
its label sleeve, inside the camera's distorted frame) over the number its whole top area would
cover unoccluded: the area of its silhouette in the same render, computed, not rendered. Every
item is one convex MuJoCo primitive (box, cylinder or capsule) and maybe a label sleeve (a
cylinder), so its silhouette is the union of the convex hulls of the projections of their
outlines: a box's 8 corners, a cylinder's two rims, a capsule's two end spheres' contour
circles as the camera sees them (circles as 24-gons of the circle's area). The fraction is the
seen share of what the camera would see of the item with nothing in the way and the whole frame
around it (its top and, off the optical axis, the flank of a tall item, as the render shows
them), in [0, 1]: covered by another item (or a cup), or partly outside the frame, it is less.

An item is *never visible* when, at every observation while it passes the camera, less than
`VISIBLE_SHARE` of its top area is seen: its largest fraction over the observations is below
that. The episode books it in `never_visible` (`sim.results.metrics`) among the items that
passed the camera: their centre reached the (first) camera's line at an observation. With a
camera per robot (a line) an item's fraction at an observation is the largest over the cameras.

The render is the pinhole canvas at `SCALE` of the camera's, cropped to the belt's width
(`belt_slope`): cheap enough to run at every observation (docs/perception.md gives its cost).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import cv2
import mujoco
import numpy as np

from sim.cell.camera import camera_id, camera_pose_of
from sim.cell.held_slots import NONE_HELD, held_mask
from sim.cell.items import Items
from sim.errors import InvalidInput
from sim.flow.config import BELT_HALF_WIDTH

VISIBLE_SHARE = 0.3
"""An item seen with less than this share of its top area at every observation while it
passes the camera is never visible."""
SCALE = 0.5
"""Pixels of the monitor's render per pixel of the camera's pinhole canvas."""
BELT_MARGIN_M = 0.05
"""How far beyond the belt's edge an item's outline may reach (a rail's width) [m]."""
TALLEST_ITEM_M = 0.25
"""Highest top of an item above the belt the crop keeps in view [m] (a standing 1.5 l bottle:
0.22 m)."""
_RIM = 24
"""Points of a circle's outline."""
_ANGLES = 2.0 * math.pi * np.arange(_RIM) / _RIM
_CIRCLE = math.sqrt(2.0 * math.pi / (_RIM * math.sin(2.0 * math.pi / _RIM))) * np.column_stack(
    [np.cos(_ANGLES), np.sin(_ANGLES)]
)
"""A unit circle's outline: a regular polygon of the circle's area."""
_CORNERS = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
_BOX, _CYLINDER, _CAPSULE = (int(mujoco.mjtGeom.mjGEOM_BOX), int(mujoco.mjtGeom.mjGEOM_CYLINDER),
                             int(mujoco.mjtGeom.mjGEOM_CAPSULE))  # fmt: skip
_SAME = mujoco.mjtSameFrame


class SlotRender(Protocol):
    """A segmentation render of a belt camera (`sim.render.segmentation.BeltSegmentation`).

    Attributes:
        name: The camera's name in the model.
        camera_matrix: (3, 3) the render's pinhole intrinsics [px].
    """

    name: str
    camera_matrix: np.ndarray

    def pixel_counts(self, data: mujoco.MjData) -> np.ndarray:
        """(pool slots,) the pixels of each slot's item inside the camera's frame."""


@dataclass(frozen=True)
class Sighting:
    """What one observation saw of the items, every camera together.

    Attributes:
        fractions: Visible fraction of its top area [0..1] of each item near a camera, by flow
            id: the largest over the cameras (0 for one outside every frame).
        passed: Flow ids of the items on the belt whose centre is at or past the first camera's
            line.
    """

    fractions: dict[int, float]
    passed: tuple[int, ...]


def belt_slope(camera_height_m: float, belt_half_width_m: float = BELT_HALF_WIDTH) -> float:
    """The largest |x / z| of a ray (camera axes: x across the belt) to an item on the belt
    `2 belt_half_width_m` [m] wide seen by a camera `camera_height_m` [m] above it: its outline
    reaches `BELT_MARGIN_M` past the belt's edge and at most `TALLEST_ITEM_M` above the belt."""
    return (belt_half_width_m + BELT_MARGIN_M) / (camera_height_m - TALLEST_ITEM_M)


def outline(kind: int, size: np.ndarray, pos: np.ndarray, mat: np.ndarray, eye: np.ndarray):
    """World points (n, 3) [m] whose convex hull, seen from `eye`, is a primitive's silhouette.

    Args:
        kind: MuJoCo geom type: box, cylinder or capsule.
        size: The geom's size (half-sizes; radius and half-length) [m].
        pos: Its centre [m] (3,).
        mat: Its rotation (3, 3), world from geom.
        eye: The camera's position [m] (3,).
    """
    if kind == _BOX:
        return pos + (_CORNERS * size[:3]) @ mat.T
    radius, half = float(size[0]), float(size[1])
    if kind == _CYLINDER:
        rim = radius * _CIRCLE @ mat[:, :2].T
        axis = half * mat[:, 2]
        return np.vstack([pos + axis + rim, pos - axis + rim])
    if kind != _CAPSULE:
        raise InvalidInput("kind", "a box, cylinder or capsule geom type", kind)
    points = []
    for end in (-half, half):
        centre = pos + end * mat[:, 2]
        ray = centre - eye
        distance = math.sqrt(ray @ ray)
        ray = ray / distance
        # A sphere seen from `eye` ends at its contour circle: nearer by r^2 / d than its
        # centre, of radius r sqrt(1 - r^2 / d^2), square to the ray.
        seed = np.array((1.0, 0.0, 0.0) if abs(ray[0]) < 0.9 else (0.0, 1.0, 0.0))
        across = seed - (seed @ ray) * ray
        across /= math.sqrt(across @ across)
        other = np.array(
            [
                ray[1] * across[2] - ray[2] * across[1],
                ray[2] * across[0] - ray[0] * across[2],
                ray[0] * across[1] - ray[1] * across[0],
            ]
        )
        rho = radius * math.sqrt(max(1.0 - (radius / distance) ** 2, 0.0))
        rim = rho * _CIRCLE @ np.stack([across, other])
        points.append(centre - ray * (radius * radius / distance) + rim)
    return np.vstack(points)


def outlines(kind: int, sizes: np.ndarray, pos: np.ndarray, mats: np.ndarray) -> np.ndarray:
    """`outline` of n boxes or n cylinders at once: world points (n, m, 3) [m], the same bit
    for bit (each product is numpy's matmul of one geom's block, the operands laid out in
    memory as `outline`'s are, so the same BLAS call; the rest is elementwise).

    Args:
        kind: MuJoCo geom type: box or cylinder.
        sizes: The geoms' sizes (n, 3) [m].
        pos: Their centres (n, 3) [m].
        mats: Their rotations (n, 3, 3), world from geom, each row-major.
    """
    if kind == _BOX:
        return pos[:, None] + (_CORNERS * sizes[:, None, :3]) @ mats.transpose(0, 2, 1)
    if kind != _CYLINDER:
        raise InvalidInput("kind", "a box or cylinder geom type (batched)", kind)
    rim = sizes[:, 0, None, None] * _CIRCLE @ mats[:, :, :2].transpose(0, 2, 1)
    axis = sizes[:, 1, None] * mats[:, :, 2]
    return np.concatenate([(pos + axis)[:, None] + rim, (pos - axis)[:, None] + rim], axis=1)


class VisibilityWatch:
    """The visible fraction of each item's top area at one observation of the belt cameras
    (see the module docstring); `renders` holds one segmentation render per camera, upstream
    first."""

    def __init__(self, renders: Sequence[SlotRender], items: Items):
        self.renders, self.items, self.pool = tuple(renders), items, items.pool
        self.model = self.pool.model
        self._cams = tuple(camera_id(self.model, render.name) for render in self.renders)

    def measure(self, held: np.ndarray = NONE_HELD) -> Sighting:
        """Render every camera's view now and measure the items near each (the `held` pool
        slots are never on the belt)."""
        self.items.kinematics()
        data = self.items.current()
        belt = self._belt(held)
        fractions: dict[int, float] = {}
        first_line = math.inf
        for render, cam in zip(self.renders, self._cams, strict=True):
            rot, eye = camera_pose_of(data, cam)
            near = self._near_of(render, eye, belt)
            # A camera no item is near sees none: its render would be counted for nothing.
            if len(near):
                counts = render.pixel_counts(data)
                seen, _ = self._fractions(render, counts, (rot, eye, near), areas=False)
                for item_id, fraction in seen.items():
                    fractions[item_id] = max(fraction, fractions.get(item_id, 0.0))
            first_line = min(first_line, float(eye[0]))
        active, centres, _ = belt
        past = centres[:, 0] >= first_line
        passed = tuple(int(i) for i in self.pool.item_ids[active[past]])
        return Sighting(fractions, passed)

    def fractions(
        self, render, counts: np.ndarray, held: np.ndarray = NONE_HELD, areas: bool = True
    ) -> tuple[dict[int, float], dict[int, float]]:
        """The visible fraction of each item near camera `render` and the pixels its whole top
        area would cover, by flow id.

        Args:
            render: The camera's segmentation render (its name, its intrinsics).
            counts: (pool slots,) the pixels of each slot's item in the camera's frame.
            held: The pool slots the cups hold.
            areas: Measure every item's area; False: only those of the items seen (an item
                with no pixel in the frame has the fraction 0 whatever its area, and no area
                in the second dict).

        Returns:
            (fractions in [0, 1], areas [px]).
        """
        return self._fractions(render, counts, self._near(render, held), areas)

    def _fractions(
        self, render, counts: np.ndarray, view: tuple, areas: bool
    ) -> tuple[dict[int, float], dict[int, float]]:
        """`fractions` of the items near camera `render` seen from where it is: `view` is
        `_near`'s (rotation, position, slots near)."""
        rot, eye, near = view
        measured = near if areas else near[counts[near] != 0]
        silhouettes = self.silhouettes_px(measured, rot, eye, render.camera_matrix)
        area_of = dict(zip(measured.tolist(), silhouettes, strict=True))
        item_ids = self.pool.item_ids
        fractions, sizes = {}, {}
        for slot in near.tolist():
            item_id = int(item_ids[slot])
            area = area_of.get(slot)
            if area is None:  # no pixel in the frame: 0 whatever its area
                fractions[item_id] = 0.0
                continue
            sizes[item_id] = area
            fractions[item_id] = min(1.0, counts[slot] / area) if area > 0.0 else 0.0
        return fractions, sizes

    def _near(self, render, held: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rotation (3, 3), position (3,) [m] of camera `render.name`, the pool slots on the
        belt near enough to show in its render): an item further along the belt than the
        render's half-height (as a slope) times the camera's height above it, plus its
        bounding radius, cannot show in it."""
        rot, eye = camera_pose_of(self.items.current(), camera_id(self.model, render.name))
        return rot, eye, self._near_of(render, eye, self._belt(held))

    def _belt(self, held: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(the active slots no cup holds, their centres [m] (n, 3), their geoms' bounding
        radii [m] (n,)), read once for every camera."""
        active = self._on_belt(held)
        centres = self.items.positions(active)
        return active, centres, self.model.geom_rbound[self.pool.active_geom[active]]

    @staticmethod
    def _near_of(render, eye: np.ndarray, belt: tuple) -> np.ndarray:
        """The slots of `belt` (`_belt`) near enough to show in camera `render` at `eye`
        (`_near`)."""
        active, centres, rbound = belt
        k = render.camera_matrix
        slope = (k[1, 2] + 1.0) / k[1, 1]
        reach = slope * (eye[2] - centres[:, 2])
        reach += rbound
        return active[np.abs(centres[:, 0] - eye[0]) <= reach]

    def _on_belt(self, held: np.ndarray) -> np.ndarray:
        """The active slots no cup holds."""
        active = self.items.active_slots()
        return active[~held_mask(active, held)]

    def silhouette_px(
        self, slot: int, rot: np.ndarray, eye: np.ndarray, camera_matrix: np.ndarray
    ) -> float:
        """The area [px] of the silhouette of the item in `slot` (its geom and its label
        sleeve) in a render of intrinsics `camera_matrix` by the camera at `eye` [m] with
        rotation `rot` (world from camera, OpenCV axes)."""
        return self.silhouettes_px(np.array([slot]), rot, eye, camera_matrix)[0]

    def silhouettes_px(
        self, slots: np.ndarray, rot: np.ndarray, eye: np.ndarray, camera_matrix: np.ndarray
    ) -> list[float]:
        """`silhouette_px` of the items in `slots` (n,), computed together (`outlines`)."""
        model, data, pool = self.model, self.items.current(), self.pool
        geoms = pool.active_geom[slots]
        mats = data.geom_xmat[geoms].reshape(-1, 3, 3)
        items = self._geom_hulls(geoms, data.geom_xpos[geoms], mats, rot, eye, camera_matrix)
        labels = pool.label_ids[slots]
        shown = (model.geom_rgba[labels, 3] > 0.0).tolist()
        sleeved = [k for k, item in enumerate(items) if item is not None and shown[k]]
        sleeves = dict.fromkeys(sleeved)
        if sleeved:
            frames = [self.label_frame(int(slots[k])) for k in sleeved]
            pos, mats = np.array([f[0] for f in frames]), np.array([f[1] for f in frames])
            points = outlines(_CYLINDER, model.geom_size[labels[sleeved]], pos, mats)
            sleeves.update(zip(sleeved, _hulls(points, rot, eye, camera_matrix), strict=True))
        return [_union_area(item, sleeves.get(k, False)) for k, item in enumerate(items)]

    def _geom_hulls(self, geoms, pos, mats, rot, eye, k) -> list:
        """`_hull` of the outline of each geom of `geoms` (n,) at `pos` (n, 3) [m] with
        rotations `mats` (n, 3, 3): boxes and cylinders together, capsules one by one."""
        model = self.model
        kinds = model.geom_type[geoms]
        hulls: list = [None] * len(geoms)
        for kind in np.unique(kinds).tolist():
            which = np.flatnonzero(kinds == kind)
            if kind in (_BOX, _CYLINDER):
                points = outlines(kind, model.geom_size[geoms[which]], pos[which], mats[which])
                for j, hull in zip(which.tolist(), _hulls(points, rot, eye, k), strict=True):
                    hulls[j] = hull
                continue
            for j in which.tolist():
                points = outline(kind, model.geom_size[geoms[j]], pos[j], mats[j], eye)
                hulls[j] = _hull(points, rot, eye, k)
        return hulls

    def label_frame(self, slot: int) -> tuple[np.ndarray, np.ndarray]:
        """(centre [m] (3,), rotation (3, 3)) of the label sleeve of the item in `slot` as
        MuJoCo poses it (`geom_sameframe`): a geom compiled in its body's or inertial frame
        (the pool's labels, generated at the body's origin) keeps that frame whatever its
        `geom_quat` says at run time; otherwise its own pose in the body."""
        model, pool = self.model, self.pool
        label, body = int(pool.label_ids[slot]), int(pool.body_ids[slot])
        body_pos = np.array(self.items.position(slot))
        body_mat = np.asarray(self.items.orientation(slot)).reshape(3, 3)
        same = int(model.geom_sameframe[label])
        if same == _SAME.mjSAMEFRAME_BODY:
            return body_pos, body_mat
        offset = body_pos + body_mat @ model.geom_pos[label]
        if same == _SAME.mjSAMEFRAME_NONE:
            return offset, body_mat @ _rotation(model.geom_quat[label])
        if same == _SAME.mjSAMEFRAME_BODYROT:
            return offset, body_mat
        inertial = body_mat @ _rotation(model.body_iquat[body])
        if same == _SAME.mjSAMEFRAME_INERTIA:
            return body_pos + body_mat @ model.body_ipos[body], inertial
        return offset, inertial


def _rotation(quat: np.ndarray) -> np.ndarray:
    """The rotation matrix (3, 3) of a unit quaternion (w, x, y, z)."""
    out = np.empty(9)
    mujoco.mju_quat2Mat(out, np.asarray(quat, dtype=np.float64))
    return out.reshape(3, 3)


def _hull(points: np.ndarray, rot: np.ndarray, eye: np.ndarray, k: np.ndarray):
    """The convex hull (m, 1, 2) float32 [px] of world `points` (n, 3) [m] in a pinhole image of
    intrinsics `k` by a camera at `eye` [m] with rotation `rot` (world from camera, OpenCV
    axes); None when a point lies behind the camera."""
    camera = (points - eye) @ rot
    if np.any(camera[:, 2] <= 1e-6):
        return None
    pixels = camera[:, :2] / camera[:, 2:] * (k[0, 0], k[1, 1]) + (k[0, 2], k[1, 2])
    return cv2.convexHull(pixels.astype(np.float32))


def _union_area(item, sleeve) -> float:
    """The area [px] of the union of an item's hull and its sleeve's (`_hull`s): 0 when either
    is None (behind the camera), the item's alone when the sleeve is False (not drawn)."""
    if item is None or sleeve is None:
        return 0.0
    if sleeve is False:
        return float(cv2.contourArea(item))
    # The union of two convex silhouettes: both areas less their overlap.
    overlap, _ = cv2.intersectConvexConvex(item, sleeve)
    return float(cv2.contourArea(item) + cv2.contourArea(sleeve) - overlap)


def _hulls(points: np.ndarray, rot: np.ndarray, eye: np.ndarray, k: np.ndarray) -> list:
    """`_hull` of each of n point sets (n, m, 3) [m], projected together (the same bits: each
    product one set's matmul, the rest elementwise)."""
    camera = (points - eye) @ rot
    behind = np.any(camera[:, :, 2] <= 1e-6, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):  # behind: no hull, whatever it is
        pixels = camera[:, :, :2] / camera[:, :, 2:] * (k[0, 0], k[1, 1]) + (k[0, 2], k[1, 2])
    pixels = pixels.astype(np.float32)
    hidden = behind.tolist()
    return [None if out else cv2.convexHull(p) for out, p in zip(hidden, pixels, strict=True)]
