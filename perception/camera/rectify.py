"""Where the belt is in the image: marker detection, camera pose, and a top-down belt image.

The calibrated camera (intrinsics + distortion) sees coloured square markers at the belt's
corners whose world positions are known from the cell's drawings (the MJCF). Their centroids in
the undistorted image and `cv2.solvePnP` give the camera's pose on the belt; from then on every
point of a plane above the belt maps to a pixel of the raw frame, so undistortion and
rectification are one `cv2.remap` onto a metric top-down image (`BeltRectifier`).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from perception.camera.calibration import CameraCalibration
from perception.errors import PerceptionError, PerceptionInputError

_HUE_TOLERANCE_DEG = 14.0


def _hue_deg(rgb: np.ndarray) -> np.ndarray:
    """Hue [deg] of RGB colours (N, 3) in [0, 1]."""
    hsv = cv2.cvtColor(np.asarray(rgb, np.float32).reshape(1, -1, 3), cv2.COLOR_RGB2HSV)
    return hsv[0, :, 0].astype(np.float64)


def colour_mask(image: np.ndarray, rgb: np.ndarray) -> np.ndarray:
    """Pixels (height, width) bool of a saturated colour `rgb` [0..1] under any brightness."""
    hsv = cv2.cvtColor(image, cv2.COLOR_RGB2HSV_FULL)
    hue = hsv[..., 0].astype(np.float64) * (360.0 / 256.0)
    delta = np.abs((hue - _hue_deg(rgb)[0] + 180.0) % 360.0 - 180.0)
    return (delta < _HUE_TOLERANCE_DEG) & (hsv[..., 1] > 200) & (hsv[..., 2] > 120)


def detect_markers(image: np.ndarray, colours: np.ndarray, min_area_px: int = 12) -> np.ndarray:
    """Centroids (N, 2) [px] of the largest blob of each marker colour (N, 3) [0..1].

    Raises:
        PerceptionError: A marker is not visible.
    """
    centres = []
    for index, rgb in enumerate(np.asarray(colours, dtype=np.float64)):
        mask = colour_mask(image, rgb).astype(np.uint8)
        count, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
        if count < 2:
            raise PerceptionError(f"marker {index} (colour {np.round(rgb, 2).tolist()}) not found")
        best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        if stats[best, cv2.CC_STAT_AREA] < min_area_px:
            raise PerceptionError(
                f"marker {index}: largest blob {stats[best, cv2.CC_STAT_AREA]} px,"
                f" {min_area_px} px needed"
            )
        centres.append(centroids[best])
    return np.array(centres, dtype=np.float64)


@dataclass(frozen=True)
class BeltView:
    """A calibrated camera at a known pose: world points to raw-frame pixels.

    Attributes:
        calibration: Intrinsics and distortion.
        rvec: (3,) Rodrigues rotation world -> camera (OpenCV axes).
        tvec: (3,) translation world -> camera [m].
        marker_rms_px: RMS reprojection error of the markers the pose was solved from [px].
    """

    calibration: CameraCalibration
    rvec: np.ndarray
    tvec: np.ndarray
    marker_rms_px: float

    def project(self, world: np.ndarray) -> np.ndarray:
        """Raw (distorted) frame pixels (N, 2) of world points (N, 3) [m]."""
        pts = np.asarray(world, dtype=np.float64).reshape(-1, 1, 3)
        cal = self.calibration
        px, _ = cv2.projectPoints(pts, self.rvec, self.tvec, cal.camera_matrix, cal.dist_coeffs)
        return px.reshape(-1, 2)

    def camera_position(self) -> np.ndarray:
        """The camera's optical centre in the world frame (3,) [m]."""
        rot, _ = cv2.Rodrigues(self.rvec)
        return -rot.T @ self.tvec


def undistort(image: np.ndarray, calibration: CameraCalibration) -> np.ndarray:
    """The pinhole image (same intrinsics, no distortion) of a raw frame."""
    return cv2.undistort(image, calibration.camera_matrix, calibration.dist_coeffs)


def locate_belt(
    image: np.ndarray,
    calibration: CameraCalibration,
    marker_world: np.ndarray,
    marker_colours: np.ndarray,
) -> BeltView:
    """The camera's pose from the markers seen in a raw frame.

    Args:
        image: Raw (distorted) RGB frame (height, width, 3) uint8.
        marker_world: (N >= 4, 3) marker centres in the world frame [m].
        marker_colours: (N, 3) their colours [0..1].
    """
    marker_world = np.asarray(marker_world, dtype=np.float64)
    if marker_world.ndim != 2 or marker_world.shape[1] != 3 or len(marker_world) < 4:
        raise PerceptionInputError("marker_world", "(N >= 4, 3) array [m]", marker_world.shape)
    pixels = detect_markers(undistort(image, calibration), marker_colours)
    matrix = calibration.camera_matrix
    planar = np.ptp(marker_world[:, 2]) < 1e-6
    method = cv2.SOLVEPNP_IPPE if planar else cv2.SOLVEPNP_SQPNP
    ok, rvec, tvec = cv2.solvePnP(marker_world, pixels, matrix, None, flags=method)
    if not ok or not np.all(np.isfinite(rvec)) or not np.all(np.isfinite(tvec)):
        raise PerceptionError("camera pose: solvePnP found no pose for the markers")
    rvec, tvec = cv2.solvePnPRefineLM(marker_world, pixels, matrix, None, rvec, tvec)
    reproj, _ = cv2.projectPoints(marker_world, rvec, tvec, matrix, None)
    rms = float(np.sqrt(np.mean(np.sum((reproj.reshape(-1, 2) - pixels) ** 2, axis=1))))
    if rms > 3.0:
        raise PerceptionError(f"camera pose: markers reproject {rms:.1f} px off, 3 px allowed")
    return BeltView(calibration, rvec.ravel(), tvec.ravel(), rms)


@dataclass(frozen=True)
class TopDownRaster:
    """A metric top-down raster of the belt: pixel (i, j) is the belt point
    x = x_min + (i + 0.5) res, y = y_min + (j + 0.5) res (rows downstream, columns from -y).

    Attributes:
        x_min: Upstream edge [m].
        y_min: -y edge [m].
        resolution_m: Side of a pixel [m].
        shape: (rows, cols).
    """

    x_min: float
    y_min: float
    resolution_m: float
    shape: tuple[int, int]

    @classmethod
    def covering(
        cls, x_range: tuple[float, float], y_range: tuple[float, float], resolution_m: float
    ) -> TopDownRaster:
        """The raster of a region [m] at `resolution_m` [m]."""
        if not 0.0002 <= resolution_m <= 0.02:
            raise PerceptionInputError("resolution_m", "0.0002..0.02 m", resolution_m)
        rows = int(round((x_range[1] - x_range[0]) / resolution_m))
        cols = int(round((y_range[1] - y_range[0]) / resolution_m))
        if rows < 1 or cols < 1:
            raise PerceptionInputError(
                "top-down region", "a non-empty x and y range", (x_range, y_range)
            )
        return cls(float(x_range[0]), float(y_range[0]), float(resolution_m), (rows, cols))

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """x of the rows' centres and y of the columns' centres [m]."""
        res = self.resolution_m
        return (
            self.x_min + (np.arange(self.shape[0]) + 0.5) * res,
            self.y_min + (np.arange(self.shape[1]) + 0.5) * res,
        )

    def rows_of(self, x_lo: float, x_hi: float) -> tuple[int, int]:
        """Row slice [start, stop) of the pixels whose centres lie in [x_lo, x_hi) [m]."""
        start = int(np.ceil((x_lo - self.x_min) / self.resolution_m - 0.5))
        stop = int(np.ceil((x_hi - self.x_min) / self.resolution_m - 0.5))
        return max(start, 0), min(stop, self.shape[0])

    def cols_of(self, y_lo: float, y_hi: float) -> tuple[int, int]:
        """Column slice [start, stop) of the pixels whose centres lie in [y_lo, y_hi) [m]."""
        start = int(np.ceil((y_lo - self.y_min) / self.resolution_m - 0.5))
        stop = int(np.ceil((y_hi - self.y_min) / self.resolution_m - 0.5))
        return max(start, 0), min(stop, self.shape[1])

    def pixel_to_world(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Belt-plane coordinates (N, 2) [m] of pixels."""
        x = self.x_min + (np.asarray(rows) + 0.5) * self.resolution_m
        y = self.y_min + (np.asarray(cols) + 0.5) * self.resolution_m
        return np.stack([x, y], axis=1)


class BeltRectifier:
    """Raw frame -> top-down image of a plane above the belt, one `cv2.remap`.

    Args:
        raster: The top-down raster (`TopDownRaster.covering`).
        plane_z: Height of the rectified plane above the belt [m].
    """

    def __init__(self, view: BeltView, raster: TopDownRaster, plane_z: float = 0.0):
        self.view = view
        self.raster = raster
        self.plane_z = float(plane_z)
        x, y = raster.centres()
        xx, yy = np.meshgrid(x, y, indexing="ij")
        world = np.stack([xx.ravel(), yy.ravel(), np.full(xx.size, plane_z)], axis=1)
        px = view.project(world).reshape(*raster.shape, 2).astype(np.float32)
        self._map1, self._map2 = cv2.convertMaps(px[..., 0], px[..., 1], cv2.CV_16SC2)

    def rectify(self, frame: np.ndarray) -> np.ndarray:
        """The top-down image (rows, cols, 3) of a raw frame."""
        return cv2.remap(frame, self._map1, self._map2, cv2.INTER_LINEAR)
