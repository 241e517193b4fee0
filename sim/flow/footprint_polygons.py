"""Item footprints on the belt plane: exact point tests and conservative convex polygons.

A footprint is the item's outline seen from above (`ItemType.footprint`, body frame: x along
the item's long axis): a rectangle, a disc or a stadium. `contains` tests points exactly (used by
the ground truth's area sampling); `polygon` gives a convex polygon that encloses the outline
(used to keep items apart when the flow is generated).
"""

from __future__ import annotations

import math

import numpy as np

from sim.flow.catalogue import ItemType

POLYGON_VERTICES = 16


def to_body(px: np.ndarray, py: np.ndarray, x: float, y: float, yaw: float):
    """Belt-plane points [m] expressed in the body frame of an item at (x, y, yaw)."""
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = px - x, py - y
    return c * dx + s * dy, -s * dx + c * dy


def contains(item_type: ItemType, lx: np.ndarray, ly: np.ndarray) -> np.ndarray:
    """Whether body-frame points (lx, ly) [m] lie inside the footprint (boolean array)."""
    kind, a, b = item_type.footprint
    if kind == "rect":
        return (np.abs(lx) <= a) & (np.abs(ly) <= b)
    if kind == "disc":
        return lx * lx + ly * ly <= a * a
    ex = np.maximum(np.abs(lx) - a, 0.0)
    return ex * ex + ly * ly <= b * b


def _local_outline(item_type: ItemType) -> np.ndarray:
    """(POLYGON_VERTICES, 2) convex outline in the body frame, enclosing the footprint."""
    kind, a, b = item_type.footprint
    if kind == "rect":
        corners = np.array([[a, b], [-a, b], [-a, -b], [a, -b]])
        return np.repeat(corners, POLYGON_VERTICES // 4, axis=0)
    if kind == "disc":
        n = POLYGON_VERTICES
        radius = a / math.cos(math.pi / n)
        angles: np.ndarray = 2 * math.pi * (np.arange(n) + 0.5) / n
        return radius * np.column_stack([np.cos(angles), np.sin(angles)])
    # Stadium: the half-disc at x = +a is enclosed by `half - 1` tangent lines from angle -pi/2
    # to +pi/2; their corners plus the two ends of the straight sides make `half` vertices.
    half = POLYGON_VERTICES // 2
    step = math.pi / (half - 2)
    angles = -math.pi / 2 + step / 2 + step * np.arange(half - 2)
    radius = b / math.cos(step / 2)
    arc = np.column_stack([a + radius * np.cos(angles), radius * np.sin(angles)])
    right = np.vstack([[a, -b], arc, [a, b]])
    return np.vstack([right, -right])


def contains_grown(item_type: ItemType, lx: np.ndarray, ly: np.ndarray, grow: float) -> np.ndarray:
    """Whether body-frame points (lx, ly) [m] lie within `grow` [m] of the footprint."""
    kind, a, b = item_type.footprint
    if kind == "rect":
        ex, ey = np.maximum(np.abs(lx) - a, 0.0), np.maximum(np.abs(ly) - b, 0.0)
        return ex * ex + ey * ey <= grow * grow
    if kind == "disc":
        return lx * lx + ly * ly <= (a + grow) ** 2
    ex = np.maximum(np.abs(lx) - a, 0.0)
    return ex * ex + ly * ly <= (b + grow) ** 2


def polygon(item_type: ItemType, x: float, y: float, yaw: float) -> np.ndarray:
    """(POLYGON_VERTICES, 2) belt-plane outline [m] enclosing the footprint at (x, y, yaw).

    Vertices go counter-clockwise; rectangles repeat each corner (zero-length edges), so every
    polygon has the same vertex count and several can be stacked.
    """
    c, s = math.cos(yaw), math.sin(yaw)
    local = _local_outline(item_type)
    return np.column_stack(
        [x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]]
    )


def edge_normals(vertices: np.ndarray) -> np.ndarray:
    """Unit outward normals of a stack of polygons (..., V, 2); zero-length edges reuse one."""
    edges = np.roll(vertices, -1, axis=-2) - vertices
    normals = np.stack([edges[..., 1], -edges[..., 0]], axis=-1)
    length = np.linalg.norm(normals, axis=-1, keepdims=True)
    valid = length[..., 0] > 1e-12
    # A zero-length edge borrows the previous valid edge's normal (a duplicate axis is harmless).
    unit = np.where(length > 1e-12, normals / np.maximum(length, 1e-300), 0.0)
    index = np.where(valid, np.arange(valid.shape[-1]), 0)
    index = np.maximum.accumulate(index, axis=-1)
    first = np.argmax(valid, axis=-1)
    index = np.where(np.arange(valid.shape[-1]) < first[..., None], first[..., None], index)
    return np.take_along_axis(unit, index[..., None], axis=-2)


def shift_intervals(
    new: np.ndarray, others: np.ndarray, clearance: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Shifts along -x that make a polygon overlap each of several others (separating axes).

    The polygon `new` (V, 2) moved by -delta along x comes closer than `clearance` [m] to
    `others[j]` (J, V, 2) exactly for delta in the open interval (lo[j], hi[j]); lo >= hi means
    never.

    Returns:
        (lo, hi): Arrays (J,) of interval bounds [m].
    """
    axes = np.concatenate(
        [np.broadcast_to(edge_normals(new), others.shape), edge_normals(others)], axis=-2
    )
    proj_new = np.einsum("vd,jad->jav", new, axes)
    proj_other = np.einsum("jvd,jad->jav", others, axes)
    min_a, max_a = proj_new.min(-1), proj_new.max(-1)
    min_b, max_b = proj_other.min(-1) - clearance, proj_other.max(-1) + clearance
    nx = axes[..., 0]
    # Along axis n the projections overlap while max_a - delta*nx > min_b and
    # min_a - delta*nx < max_b.
    tiny = np.abs(nx) < 1e-12
    safe = np.where(tiny, 1.0, nx)
    bound_1 = (max_a - min_b) / safe
    bound_2 = (min_a - max_b) / safe
    lower = np.where(nx > 0, bound_2, bound_1)
    upper = np.where(nx > 0, bound_1, bound_2)
    static = (max_a > min_b) & (min_a < max_b)
    lower = np.where(tiny, np.where(static, -np.inf, np.inf), lower)
    upper = np.where(tiny, np.where(static, np.inf, -np.inf), upper)
    return lower.max(-1), upper.min(-1)
