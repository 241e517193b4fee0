"""Checks of the camera pipeline's geometry against the simulator's true camera.

Perception never sees these truths; tests and the benchmark use them to measure it: where the
grid's cell corners really fall on the belt, and how straight the belt's edges are after
undistortion.
"""

from __future__ import annotations

import cv2
import mujoco
import numpy as np

from perception.camera.grid import BeltGrid
from perception.camera.lens import LensModel
from perception.camera.rectify import BeltView
from sim.cell.camera import camera_pose

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


def grid_overlay(
    image: np.ndarray,
    matrix: np.ndarray,
    view: BeltView,
    speed: float,
    rows: int = 7,
    grid: BeltGrid | None = None,
) -> np.ndarray:
    """The undistorted image with the belt grid drawn on it (thesis figure 2.13 c): stripe
    boundaries and the row boundaries of `rows` rows centred on the camera line."""
    grid = grid or BeltGrid()
    out = image.copy()
    pitch = grid.row_pitch(speed)
    x_lo = grid.x_line - pitch * (rows / 2)
    xs = x_lo + pitch * np.arange(rows + 1)
    ys = grid.stripe_edges()
    lines = [[(x, y) for y in np.linspace(ys[0], ys[-1], 40)] for x in xs]
    lines += [[(x, y) for x in np.linspace(xs[0], xs[-1], 40)] for y in ys]
    for line in lines:
        world = np.c_[np.asarray(line), np.zeros(len(line))]
        px, _ = cv2.projectPoints(world, view.rvec, view.tvec, matrix, None)
        cv2.polylines(out, [np.round(px).astype(np.int32)], False, (255, 220, 0), 1, cv2.LINE_AA)
    return out


def main() -> int:
    """Prints the camera geometry figures: calibration against the renderer, straightness of
    the belt's edges before and after undistortion, grid corner errors on the belt; with
    `--figure PATH` also writes the thesis's figure 2.13 for the cell (raw, undistorted, grid)."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m sim.evaluation.camera_checks", description=main.__doc__
    )
    parser.add_argument("--figure", default=None, help="PNG of raw / undistorted / grid frames")
    args = parser.parse_args()
    from perception.camera.calibration import CameraCalibration
    from perception.camera.lens import ZED_HD_LEFT
    from perception.camera.rectify import locate_belt, undistort
    from sim.cell.camera import DEFAULT_CALIBRATION, BeltCamera, marker_points, true_camera_matrix
    from sim.paths import SCENE_XML

    size = (1280, 720)
    calibration = CameraCalibration.load(DEFAULT_CALIBRATION).scaled(size)
    scene = mujoco.MjModel.from_xml_path(str(SCENE_XML))
    truth = true_camera_matrix(scene, *size)
    focal = calibration.camera_matrix[[0, 1], [0, 1]] / truth[0, 0] - 1.0
    print(
        f"calibration {DEFAULT_CALIBRATION.name}: focal error {100 * focal[0]:+.3f} % (fx),"
        f" {100 * focal[1]:+.3f} % (fy); RMS reprojection {calibration.rms_px:.3f} px,"
        f" {calibration.n_views} views"
    )
    fixture = scene  # the cell's belt and markers (the items are parked off-stage)
    data = mujoco.MjData(fixture)
    mujoco.mj_forward(fixture, data)
    with BeltCamera(fixture, *size) as camera:
        frame = camera.render(data)
    rows = [v for v in range(20, 700, 4) if not 280 <= v <= 440]
    for name, image in (("raw", frame), ("undistorted", undistort(frame, calibration))):
        grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
        left, right = edge_residual(grey, rows, 370, 285), edge_residual(grey, rows, 910, 995)
        print(
            f"belt edges, {name:>11} frame: {left:.3f} px / {right:.3f} px from straight"
            " (largest residual of a line fit over the frame height, fixture, 1280x720)"
        )
    data = mujoco.MjData(scene)
    mujoco.mj_forward(scene, data)
    with BeltCamera(scene, *size) as camera:
        frame = camera.render(data)
    view = locate_belt(frame, calibration, *marker_points(scene, data))
    print(f"camera pose from the markers: reprojection RMS {view.marker_rms_px:.3f} px")
    if args.figure:
        import imageio.v3 as iio

        straight = undistort(frame, calibration)
        overlay = grid_overlay(straight, calibration.camera_matrix, view, 0.185)
        iio.imwrite(args.figure, np.vstack([frame, straight, overlay]))
        print(f"figure written: {args.figure} (raw, undistorted, grid at x1)")
    for factor in (1.0, 1.2, 1.5):
        errors = grid_corner_errors(scene, data, truth, ZED_HD_LEFT, view, 0.185 * factor)
        print(
            f"grid corners at x{factor:g}: {1000 * errors.max():.2f} mm max,"
            f" {1000 * errors.mean():.2f} mm mean on the belt (cell scene, 1280x720)"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
