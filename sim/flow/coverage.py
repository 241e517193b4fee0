"""Exact area of a convex polygon inside axis-aligned rectangles (Green's theorem, vectorised).

The boundary of P n R is made of P's edges clipped to R (Liang-Barsky) and of R's sides inside
P (Cyrus-Beck); the area is the integral of x dy along it. Edges of P that lie on a side of R
count when P is on R's side of that line, and R's sides count only where strictly inside P, so
an item whose edge coincides with a cell border is counted once, in the right cell.
Footprint outlines for this are fine polygons: curved parts get `ARC_VERTICES` vertices per
full turn, with the radius scaled so the polygon keeps the exact area of the disc or stadium.
"""

from __future__ import annotations

import math

import numpy as np

from sim.flow.catalogue import ItemType

ARC_VERTICES = 64
_EPS = 1e-12


def _arc(centre_x: float, radius: float, start: float, count: int) -> np.ndarray:
    angles = start + 2 * math.pi * np.arange(count) / ARC_VERTICES
    return np.column_stack([centre_x + radius * np.cos(angles), radius * np.sin(angles)])


def local_outline(item_type: ItemType) -> np.ndarray:
    """(V, 2) counter-clockwise polygon of the footprint in the body frame, same area."""
    kind, a, b = item_type.footprint
    if kind == "rect":
        return np.array([[a, -b], [a, b], [-a, b], [-a, -b]])
    n = ARC_VERTICES
    # A regular n-gon of circumradius R has area (n/2) R^2 sin(2 pi / n): scale R to keep pi r^2.
    scale = math.sqrt(math.pi / (n / 2 * math.sin(2 * math.pi / n)))
    if kind == "disc":
        return _arc(0.0, a * scale, 0.0, n)
    # Stadium: half-arcs at x = +-a; the straight sides stay at y = +-b, the arcs' vertices are
    # scaled to keep the two half-discs' area.
    right = _arc(a, b * scale, -math.pi / 2, n // 2 + 1)
    right[[0, -1], 1] = [-b, b]
    right[[0, -1], 0] = a
    return np.vstack([right, -right])


def outline(item_type: ItemType, x: float, y: float, yaw: float) -> np.ndarray:
    """(V, 2) counter-clockwise footprint polygon [m] at pose (x, y, yaw)."""
    c, s = math.cos(yaw), math.sin(yaw)
    local = local_outline(item_type)
    return np.column_stack(
        [x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]]
    )


def polygon_rect_areas(
    poly: np.ndarray, x0: np.ndarray, x1: np.ndarray, y0: np.ndarray, y1: np.ndarray
) -> np.ndarray:
    """Area [m^2] of the convex ccw polygon `poly` (V, 2) inside each rectangle [x0,x1]x[y0,y1].

    Coordinates should be near the polygon (subtract a common origin first) for precision.
    """
    x0, x1, y0, y1 = (np.asarray(v, dtype=float)[:, None] for v in (x0, x1, y0, y1))
    px, py = poly[:, 0][None, :], poly[:, 1][None, :]
    dx, dy = np.roll(poly[:, 0], -1)[None, :] - px, np.roll(poly[:, 1], -1)[None, :] - py
    # Liang-Barsky: boundary k keeps t with p_k t <= q_k; a parallel edge on the boundary line
    # (q_k = 0) is kept when P lies on R's side, i.e. when P's outward normal (dy, -dx) points
    # out of R there.
    t_in = np.zeros(np.broadcast(x0, px).shape)
    t_out = np.ones_like(t_in)
    keep = np.ones(t_in.shape, dtype=bool)
    for p, q, on_side in (
        (-dx, px - x0, dy < 0),
        (dx, x1 - px, dy > 0),
        (-dy, py - y0, dx > 0),
        (dy, y1 - py, dx < 0),
    ):
        parallel = np.abs(p) < _EPS
        keep &= ~parallel | (q > _EPS) | ((np.abs(q) <= _EPS) & on_side)
        ratio = q / np.where(parallel, 1.0, p)
        t_in = np.where(~parallel & (p < 0), np.maximum(t_in, ratio), t_in)
        t_out = np.where(~parallel & (p > 0), np.minimum(t_out, ratio), t_out)
    keep &= t_in < t_out
    xa, xb = px + t_in * dx, px + t_out * dx
    edges = np.where(keep, 0.5 * (xa + xb) * (t_out - t_in) * dy, 0.0).sum(axis=1)
    # Cyrus-Beck: the part of each vertical side of R strictly inside P.
    length = np.hypot(dx, dy)
    valid = length > _EPS
    nx = np.where(valid, dy / np.where(valid, length, 1.0), 0.0)
    ny = np.where(valid, -dx / np.where(valid, length, 1.0), 0.0)
    c = nx * px + ny * py

    def inside_length(xs: np.ndarray) -> np.ndarray:
        rhs = c - _EPS - nx * xs
        flat = np.abs(ny) < _EPS
        bound = rhs / np.where(flat, 1.0, ny)
        lo = np.maximum(y0[:, 0], np.where(~flat & (ny < 0), bound, -np.inf).max(axis=1))
        hi = np.minimum(y1[:, 0], np.where(~flat & (ny > 0), bound, np.inf).min(axis=1))
        blocked = (valid & flat & (rhs <= 0)).any(axis=1)
        return np.where(blocked, 0.0, np.maximum(hi - lo, 0.0))

    return edges + x1[:, 0] * inside_length(x1) - x0[:, 0] * inside_length(x0)
