"""Checks of the camera pipeline's geometry against the simulator's true camera.

Perception never sees these truths; tests and the benchmark use them to measure it: where the
grid's cell corners really fall on the belt, and how straight the belt's edges are after
undistortion.
"""

from __future__ import annotations

import cv2
import mujoco
import numpy as np

from perception.grid import BeltGrid
from perception.lens import LensModel
from perception.rectify import BeltView
from sim.camera import camera_pose

_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)


def grid_corner_errors(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    true_matrix: np.ndarray,
    lens: LensModel,
    view: BeltView,
    speed: float,
    grid: BeltGrid | None = None,
) -> np.ndarray:
    """Distances [m] on the belt between each cell corner and where the pipeline puts it.

    The pipeline's view projects the corners into the frame; those pixels are cast back onto
    the belt (z = 0) through the true camera (renderer intrinsics, applied lens, MJCF pose).
    """
    corners = (grid or BeltGrid()).cell_corners(speed).reshape(-1, 3)
    pixels = view.project(corners).reshape(-1, 1, 2)
    norm = cv2.undistortPoints(
        pixels, true_matrix, lens.dist_coeffs(), None, None, None, _CRITERIA
    ).reshape(-1, 2)
    rot, pos = camera_pose(model, data)
    rays = np.c_[norm, np.ones(len(norm))] @ rot.T
    hits = pos + rays * (-pos[2] / rays[:, 2:3])
    return np.linalg.norm(hits[:, :2] - corners[:, :2], axis=1)


def edge_residual(grey: np.ndarray, rows: list[int], lo: int, hi: int) -> float:
    """Largest distance [px] of a dark-to-bright edge from its fitted straight line.

    On each of `rows`, the edge is the first crossing, from column `lo` towards `hi` (either
    direction), of the level halfway between the darkest and brightest pixel, interpolated to
    a fraction of a pixel.
    """
    step = 1 if hi > lo else -1
    cols = []
    for v in rows:
        profile = grey[v, lo:hi:step].astype(np.float64)
        level = 0.5 * (profile.min() + profile.max())
        k = int(np.argmax(profile > level))
        frac = (level - profile[k - 1]) / (profile[k] - profile[k - 1])
        cols.append(lo + step * (k - 1 + frac))
    rows_f = np.asarray(rows, dtype=np.float64)
    fit = np.polyfit(rows_f, cols, 1)
    return float(np.max(np.abs(np.polyval(fit, rows_f) - cols)))
