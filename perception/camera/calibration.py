"""Camera calibration from checkerboard images (Zhang's method through OpenCV).

As on a real cell: a printed checkerboard is held in 15+ poses in front of the camera, the inner
corners are found (`cv2.findChessboardCorners`, refined with `cv2.cornerSubPix`) and
`cv2.calibrateCamera` estimates the intrinsics and the lens's distortion (k1, k2, p1, p2, k3).
The result is a JSON file the pipeline loads.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from perception.errors import PerceptionError, PerceptionInputError

MIN_VIEWS = 10
_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)


@dataclass(frozen=True)
class CameraCalibration:
    """A calibrated camera.

    Attributes:
        camera_matrix: (3, 3) intrinsics [px].
        dist_coeffs: (5,) distortion (k1, k2, p1, p2, k3).
        image_size: (width, height) [px] the calibration holds for.
        rms_px: RMS reprojection error of the calibration's corners [px].
        n_views: Number of checkerboard views used.
    """

    camera_matrix: np.ndarray
    dist_coeffs: np.ndarray
    image_size: tuple[int, int]
    rms_px: float
    n_views: int

    def __post_init__(self) -> None:
        if np.shape(self.camera_matrix) != (3, 3):
            raise PerceptionInputError(
                "camera_matrix", "a 3x3 matrix", np.shape(self.camera_matrix)
            )
        if np.shape(self.dist_coeffs) != (5,):
            raise PerceptionInputError("dist_coeffs", "5 numbers", np.shape(self.dist_coeffs))
        if len(self.image_size) != 2 or min(self.image_size) < 16:
            raise PerceptionInputError("image_size", "(width, height) >= 16 px", self.image_size)

    def save(self, path: Path) -> None:
        """Writes the calibration as JSON."""
        text = {
            "image_size": [int(v) for v in self.image_size],
            "camera_matrix": np.asarray(self.camera_matrix).tolist(),
            "dist_coeffs": {
                k: float(v)
                for k, v in zip(("k1", "k2", "p1", "p2", "k3"), self.dist_coeffs, strict=True)
            },
            "rms_px": float(self.rms_px),
            "n_views": int(self.n_views),
        }
        Path(path).write_text(json.dumps(text, indent=2) + "\n")

    @classmethod
    def load(cls, path: Path) -> CameraCalibration:
        """Reads a calibration written by `save`; PerceptionInputError if it is not one."""
        try:
            raw = json.loads(Path(path).read_text())
            dist = raw["dist_coeffs"]
            return cls(
                camera_matrix=np.array(raw["camera_matrix"], dtype=np.float64),
                dist_coeffs=np.array([dist[k] for k in ("k1", "k2", "p1", "p2", "k3")]),
                image_size=(int(raw["image_size"][0]), int(raw["image_size"][1])),
                rms_px=float(raw["rms_px"]),
                n_views=int(raw["n_views"]),
            )
        except (OSError, ValueError, KeyError, TypeError, IndexError) as err:
            raise PerceptionInputError(
                "calibration file", "a JSON file of `sortsim calibrate`", str(path)
            ) from err

    def scaled(self, image_size: tuple[int, int]) -> CameraCalibration:
        """The same camera at another resolution of the same aspect ratio."""
        sx = image_size[0] / self.image_size[0]
        sy = image_size[1] / self.image_size[1]
        if abs(sx - sy) > 1e-3:
            raise PerceptionInputError(
                "image_size", f"aspect ratio of {self.image_size}", image_size
            )
        matrix = np.array(self.camera_matrix, dtype=np.float64).copy()
        matrix[0, :] *= sx
        matrix[1, :] *= sy
        # OpenCV puts pixel centres at integers: the principal point scales about -0.5.
        matrix[0, 2] = (self.camera_matrix[0, 2] + 0.5) * sx - 0.5
        matrix[1, 2] = (self.camera_matrix[1, 2] + 0.5) * sy - 0.5
        return CameraCalibration(
            matrix, self.dist_coeffs, tuple(image_size), self.rms_px, self.n_views
        )


def checkerboard_points(pattern: tuple[int, int], square_m: float) -> np.ndarray:
    """Board-frame coordinates (N, 3) [m] of the inner corners, row-major as OpenCV finds them."""
    cols, rows = pattern
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square_m
    return np.hstack([grid, np.zeros((len(grid), 1))]).astype(np.float32)


def find_corners(image: np.ndarray, pattern: tuple[int, int]) -> np.ndarray | None:
    """Sub-pixel inner corners (N, 1, 2) of a checkerboard in an RGB image; None if not found."""
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    found, corners = cv2.findChessboardCorners(grey, pattern, flags=flags)
    if not found:
        return None
    return cv2.cornerSubPix(grey, corners, (5, 5), (-1, -1), _SUBPIX_CRITERIA)


def calibrate(
    images: list[np.ndarray], pattern: tuple[int, int], square_m: float
) -> CameraCalibration:
    """Calibrates a camera from checkerboard images.

    Args:
        images: RGB frames (height, width, 3) uint8 of the board in different poses.
        pattern: Inner corners (columns, rows) of the board.
        square_m: Side of a square [m].

    Raises:
        PerceptionError: Fewer than MIN_VIEWS images show the whole board.
    """
    if not images:
        raise PerceptionInputError("images", "one or more RGB frames", 0)
    height, width = images[0].shape[:2]
    board = checkerboard_points(pattern, square_m)
    object_points, image_points = [], []
    for image in images:
        if image.shape[:2] != (height, width):
            raise PerceptionInputError("images", f"all of shape {(height, width)}", image.shape)
        corners = find_corners(image, pattern)
        if corners is not None:
            object_points.append(board)
            image_points.append(corners)
    if len(image_points) < MIN_VIEWS:
        raise PerceptionError(
            f"calibration: the board was found in {len(image_points)} of {len(images)} images,"
            f" {MIN_VIEWS} needed"
        )
    rms, matrix, dist, _, _ = cv2.calibrateCamera(
        object_points, image_points, (width, height), None, None
    )
    return CameraCalibration(
        matrix, dist.ravel()[:5], (width, height), float(rms), len(image_points)
    )
