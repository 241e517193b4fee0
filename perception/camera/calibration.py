"""Camera calibration from checkerboard images (Zhang's method through OpenCV).

As on a real cell: a printed checkerboard is held in 15+ poses in front of the camera, the inner
corners are found (`cv2.findChessboardCorners`, refined with `cv2.cornerSubPix`) and
`cv2.calibrateCamera` estimates the intrinsics and the lens's distortion (k1, k2, p1, p2, k3).
The result is a JSON file the pipeline loads, written atomically (a temporary beside it, named
`.<name>.<pid>.<token>.tmp` as all the project's temporaries are, then a rename). Loading
refuses in one line, naming the field and the file, anything that is not such a file: unreadable,
not UTF-8 or not JSON, a missing field, NaN or infinite numbers, or values out of range.
"""

from __future__ import annotations

import json
import math
import os
import secrets
from dataclasses import dataclass
from pathlib import Path
from typing import cast

import cv2
import numpy as np

from perception.errors import PerceptionError, PerceptionInputError

MIN_VIEWS = 10
_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
DIST_NAMES = ("k1", "k2", "p1", "p2", "k3")
MAX_SIZE_PX = 16384
"""Largest frame side a calibration may hold [px]."""
MAX_DISTORTION = 1e3
"""Largest magnitude of a distortion coefficient accepted (real lenses: |k| < 10)."""


def _integer(value: object) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


def _real(value: object) -> bool:
    return isinstance(value, int | float | np.number) and not isinstance(value, bool)


def _no_nan(name: str) -> float:
    # json's hook for NaN and Infinity: refused where they are read.
    raise PerceptionInputError("file", "finite numbers", name)


def _read_json(path: Path, where: str) -> object:
    """The JSON value of the file at `path`, refused in one line naming `where`."""
    try:
        return json.loads(path.read_bytes().decode("utf-8"), parse_constant=_no_nan)
    except OSError as err:
        reason = err.strerror or type(err).__name__
        raise PerceptionInputError("file", "a readable JSON file", reason, where) from None
    except UnicodeDecodeError as err:
        got = f"not UTF-8 at byte {err.start}"
        raise PerceptionInputError("file", "UTF-8 JSON text", got, where) from None
    except PerceptionInputError as err:
        raise PerceptionInputError(err.field, err.allowed, err.got, where) from None
    except ValueError as err:
        reason = " ".join(str(err).split())[:120]
        raise PerceptionInputError("file", "JSON of `sortsim calibrate`", reason, where) from None


def _check_layout(raw: object) -> None:
    """Refuse JSON not laid out as `save` writes it: an object of the five fields, the
    distortion by name, the sizes integers, the matrix 3x3, every value a number."""
    if not isinstance(raw, dict):
        raise PerceptionInputError("file", "a JSON object", type(raw).__name__)
    for key in ("image_size", "camera_matrix", "dist_coeffs", "rms_px", "n_views"):
        if key not in raw:
            raise PerceptionInputError(key, "present (as `sortsim calibrate` writes it)")
    dist = raw["dist_coeffs"]
    if not isinstance(dist, dict) or set(dist) != set(DIST_NAMES):
        raise PerceptionInputError("dist_coeffs", f"an object of {DIST_NAMES}", dist)
    size = raw["image_size"]
    if not isinstance(size, list) or len(size) != 2 or not all(_integer(v) for v in size):
        raise PerceptionInputError("image_size", "[width, height] integers [px]", size)
    if not _integer(raw["n_views"]):
        raise PerceptionInputError("n_views", "an integer >= 1", raw["n_views"])
    _check_numbers(raw["camera_matrix"], dist, raw["rms_px"])


def _check_numbers(rows: object, dist: dict, rms_px: object) -> None:
    """Refuse a camera matrix that is not 3 rows of 3 numbers, or distortion or RMS that are
    not numbers."""
    if (
        not isinstance(rows, list)
        or len(rows) != 3
        or not all(isinstance(r, list) and len(r) == 3 for r in rows)
    ):
        raise PerceptionInputError("camera_matrix", "a 3x3 matrix (3 rows of 3)", None)
    for key, values in (("camera_matrix", sum(rows, [])), ("dist_coeffs", dist.values())):
        if not all(_real(v) for v in values):
            raise PerceptionInputError(key, "numbers", None)
    if not _real(rms_px):
        raise PerceptionInputError("rms_px", "a number [px]", rms_px)


def check_calibration(cal: CameraCalibration) -> None:
    """Refuse a calibration that no camera could have: wrong shapes, NaN or infinite numbers,
    a focal length <= 0 or a principal point off the image, and so on.

    Raises:
        PerceptionInputError: naming the field.
    """
    size = cal.image_size
    if len(size) != 2 or not all(_integer(v) and 16 <= v <= MAX_SIZE_PX for v in size):
        raise PerceptionInputError("image_size", f"(width, height), 16..{MAX_SIZE_PX} px", size)
    matrix = np.asarray(cal.camera_matrix)
    if matrix.shape != (3, 3) or matrix.dtype.kind not in "fiu":
        raise PerceptionInputError("camera_matrix", "a 3x3 matrix", np.shape(matrix))
    if not np.all(np.isfinite(matrix)):
        raise PerceptionInputError("camera_matrix", "finite numbers", "NaN or infinite")
    width, height = size
    fx, fy, cx, cy = matrix[0, 0], matrix[1, 1], matrix[0, 2], matrix[1, 2]
    limit = 100.0 * max(size)
    if not (0 < fx <= limit and 0 < fy <= limit):
        allowed = f"focal lengths fx, fy in (0, {limit:g}] px"
        raise PerceptionInputError("camera_matrix", allowed, (float(fx), float(fy)))
    if not (0 <= cx <= width and 0 <= cy <= height):
        allowed = f"a principal point inside the {width}x{height} image"
        raise PerceptionInputError("camera_matrix", allowed, (float(cx), float(cy)))
    if matrix[1, 0] != 0 or not np.array_equal(matrix[2], [0.0, 0.0, 1.0]):
        allowed = "the form [[fx, s, cx], [0, fy, cy], [0, 0, 1]]"
        raise PerceptionInputError("camera_matrix", allowed, matrix.tolist())
    dist = np.asarray(cal.dist_coeffs)
    if dist.shape != (5,) or dist.dtype.kind not in "fiu":
        raise PerceptionInputError("dist_coeffs", "5 numbers", np.shape(dist))
    if not np.all(np.isfinite(dist)) or np.any(np.abs(dist) > MAX_DISTORTION):
        allowed = f"5 finite numbers of magnitude <= {MAX_DISTORTION:g}"
        raise PerceptionInputError("dist_coeffs", allowed, dist.tolist())
    if not (_real(cal.rms_px) and math.isfinite(cal.rms_px) and cal.rms_px >= 0):
        raise PerceptionInputError("rms_px", "a finite number >= 0 [px]", cal.rms_px)
    if not (_integer(cal.n_views) and cal.n_views >= 1):
        raise PerceptionInputError("n_views", "an integer >= 1", cal.n_views)


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
        check_calibration(self)

    def save(self, path: Path) -> None:
        """Writes the calibration as JSON, atomically (a killed run leaves the old file)."""
        text = {
            "image_size": [int(v) for v in self.image_size],
            "camera_matrix": np.asarray(self.camera_matrix).tolist(),
            "dist_coeffs": {k: float(v) for k, v in zip(DIST_NAMES, self.dist_coeffs, strict=True)},
            "rms_px": float(self.rms_px),
            "n_views": int(self.n_views),
        }
        path = Path(path)
        data = (json.dumps(text, indent=2, allow_nan=False) + "\n").encode("utf-8")
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
        try:
            with open(tmp, "xb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise

    @classmethod
    def load(cls, path: Path) -> CameraCalibration:
        """Reads a calibration written by `save`.

        Raises:
            PerceptionInputError: one line naming the file and what is wrong with it.
        """
        where = f"calibration file {path}"
        raw = _read_json(Path(path), where)
        try:
            _check_layout(raw)
            assert isinstance(raw, dict)  # _check_layout refuses anything else
            dist = raw["dist_coeffs"]
            return cls(
                camera_matrix=np.array(raw["camera_matrix"], dtype=np.float64),
                dist_coeffs=np.array([dist[k] for k in DIST_NAMES], dtype=np.float64),
                image_size=(raw["image_size"][0], raw["image_size"][1]),
                rms_px=float(raw["rms_px"]),
                n_views=raw["n_views"],
            )
        except PerceptionInputError as err:
            raise PerceptionInputError(err.field, err.allowed, err.got, where) from None

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
            matrix,
            self.dist_coeffs,
            cast(tuple[int, int], tuple(image_size)),
            self.rms_px,
            self.n_views,
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
