"""A real lens on a pinhole render: Brown-Conrady radial (k1, k2, k3) and tangential (p1, p2).

MuJoCo renders an ideal pinhole image. A real camera's lens bends the rays, so the image the
cell's computer receives is distorted; the pipeline's first step undoes that (thesis 2.2.5,
figure 2.13). `LensDistorter` produces that distorted image from a pinhole render by inverse
mapping: for every pixel of the distorted output it finds the undistorted ray (OpenCV's
iterative `undistortPointsIter`) and samples the pinhole image there with `cv2.remap`.

The default coefficients are those of a ZED stereo camera's left lens at 1280x720, as the
factory calibration file of one such camera lists them (SN*.conf, section [LEFT_CAM_HD]).
"""

from __future__ import annotations

import functools
import hashlib
import platform
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from perception.errors import PerceptionInputError


@dataclass(frozen=True)
class LensModel:
    """OpenCV's 5-coefficient distortion model (k1, k2, p1, p2, k3), dimensionless."""

    k1: float = -0.170704
    k2: float = 0.0249542
    p1: float = 9.55189e-05
    p2: float = -0.000109509
    k3: float = 0.0

    def __post_init__(self) -> None:
        for name in ("k1", "k2", "p1", "p2", "k3"):
            value = getattr(self, name)
            if not np.isfinite(value) or abs(value) > 1.0:
                raise PerceptionInputError(f"lens.{name}", "a finite number in [-1, 1]", value)

    def dist_coeffs(self) -> np.ndarray:
        """(5,) array in OpenCV's order (k1, k2, p1, p2, k3)."""
        return np.array([self.k1, self.k2, self.p1, self.p2, self.k3], dtype=np.float64)


ZED_HD_LEFT = LensModel()
"""The ZED's left lens at 1280x720 (factory calibration values)."""

_ITER_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-10)


def _undistorted_normalised(
    pixels: np.ndarray, camera_matrix: np.ndarray, lens: LensModel
) -> np.ndarray:
    """Normalised undistorted image coordinates (N, 2) of distorted pixels (N, 2)."""
    points = pixels.reshape(-1, 1, 2).astype(np.float64)
    out = cv2.undistortPoints(
        points, camera_matrix, lens.dist_coeffs(), None, None, None, _ITER_CRITERIA
    )
    return out.reshape(-1, 2)


def _border(r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
    """(N, 2) pixels (column, row) on the outline of rows r0..r1-1 and columns c0..c1-1."""
    return np.concatenate(
        [
            np.stack([np.arange(c0, c1), np.full(c1 - c0, r0)], 1),
            np.stack([np.arange(c0, c1), np.full(c1 - c0, r1 - 1)], 1),
            np.stack([np.full(r1 - r0, c0), np.arange(r0, r1)], 1),
            np.stack([np.full(r1 - r0, c1 - 1), np.arange(r0, r1)], 1),
        ]
    ).astype(np.float64)


def source_canvas(
    camera_matrix: np.ndarray, lens: LensModel, size: tuple[int, int], margin_px: int = 4
) -> tuple[np.ndarray, tuple[int, int]]:
    """The pinhole canvas a distorted image of `size` samples from.

    Barrel distortion shows rays from outside the pinhole field of the same focal length, so the
    pinhole render must be larger. Returns the canvas's camera matrix (same focal lengths, the
    principal point moved to keep the optical axis) and its size (width, height) [px].
    """
    width, height = size
    norm = _undistorted_normalised(_border(0, height, 0, width), camera_matrix, lens)
    fx, fy = camera_matrix[0, 0], camera_matrix[1, 1]
    cx, cy = camera_matrix[0, 2], camera_matrix[1, 2]
    half_w = max(np.max(np.abs(norm[:, 0])) * fx, cx, width - 1 - cx) + margin_px
    half_h = max(np.max(np.abs(norm[:, 1])) * fy, cy, height - 1 - cy) + margin_px
    src_w, src_h = 2 * int(np.ceil(half_w)) + 2, 2 * int(np.ceil(half_h)) + 2
    src_matrix = camera_matrix.astype(np.float64).copy()
    src_matrix[0, 2] = (src_w - 1) / 2.0
    src_matrix[1, 2] = (src_h - 1) / 2.0
    return src_matrix, (src_w, src_h)


def window_source(
    camera_matrix: np.ndarray,
    lens: LensModel,
    source_matrix: np.ndarray,
    window: tuple[slice, slice],
    margin_px: int = 3,
) -> tuple[np.ndarray, tuple[int, int], tuple[int, int]]:
    """The part of a pinhole canvas (`source_canvas`) that a window of the distorted image
    samples from, centred on the optical axis so that it renders with the same focal length.

    Args:
        camera_matrix: (3, 3) intrinsics of the distorted image [px].
        source_matrix: (3, 3) intrinsics of the whole canvas [px] (principal point at its
            centre, as `source_canvas` places it).
        window: (rows, columns) slices of the distorted image (steps of 1).
        margin_px: Canvas pixels kept beyond the outermost one sampled (bilinear reads two).

    Returns:
        (matrix, size, offset): the part's intrinsics, its (width, height) [px] and where its
        first pixel lies on the whole canvas (column, row) [px], integers, so that both sample
        the same rays.
    """
    rows, cols = window
    r0, r1 = int(rows.start), int(rows.stop)
    c0, c1 = int(cols.start), int(cols.stop)
    if not (0 <= r0 < r1 and 0 <= c0 < c1):
        raise PerceptionInputError("window", "non-empty rows and columns from 0", window)
    norm = _undistorted_normalised(_border(r0, r1, c0, c1), camera_matrix, lens)
    # The window's rays may all lie on one side of the axis; the part spans both sides.
    half_w = np.max(np.abs(norm[:, 0])) * source_matrix[0, 0] + margin_px
    half_h = np.max(np.abs(norm[:, 1])) * source_matrix[1, 1] + margin_px
    full_w, full_h = (
        int(round(2 * source_matrix[0, 2])) + 1,
        int(round(2 * source_matrix[1, 2])) + 1,
    )
    width = min(2 * int(np.ceil(half_w)) + 2, full_w)
    height = min(2 * int(np.ceil(half_h)) + 2, full_h)
    # Same parity as the canvas: the part's centre is the canvas's, an integer offset away.
    width += (full_w - width) % 2
    height += (full_h - height) % 2
    matrix = source_matrix.astype(np.float64).copy()
    matrix[0, 2], matrix[1, 2] = (width - 1) / 2.0, (height - 1) / 2.0
    offset = ((full_w - width) // 2, (full_h - height) // 2)
    return matrix, (width, height), offset


def distortion_maps(
    camera_matrix: np.ndarray,
    lens: LensModel,
    size: tuple[int, int],
    source_matrix: np.ndarray,
    source_size: tuple[int, int],
    window: tuple[slice, slice] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """`cv2.remap`'s fixed-point maps of a `LensDistorter` (its arguments): (rows, columns, 2)
    int16 source pixels and (rows, columns) uint16 interpolation table entries (`CV_16SC2`)."""
    rows, cols = _window(size, window)
    u, v = np.meshgrid(
        np.arange(cols.start, cols.stop, dtype=np.float64),
        np.arange(rows.start, rows.stop, dtype=np.float64),
    )
    out_h, out_w = u.shape
    norm = _undistorted_normalised(np.stack([u.ravel(), v.ravel()], 1), camera_matrix, lens)
    map_x = source_matrix[0, 0] * norm[:, 0] + source_matrix[0, 2]
    map_y = source_matrix[1, 1] * norm[:, 1] + source_matrix[1, 2]
    map1, map2 = cv2.convertMaps(
        map_x.reshape(out_h, out_w).astype(np.float32),
        map_y.reshape(out_h, out_w).astype(np.float32),
        cv2.CV_16SC2,
    )
    return map1, map2


def distortion_maps_key(
    camera_matrix: np.ndarray,
    lens: LensModel,
    size: tuple[int, int],
    source_matrix: np.ndarray,
    source_size: tuple[int, int],
    window: tuple[slice, slice] | None = None,
) -> str:
    """A digest (40 hex digits) of everything `distortion_maps` of these arguments depends on:
    the arguments (the matrices' values and types), the code (this module, the OpenCV and NumPy
    versions and OpenCV's build for this processor): maps kept under it are those it makes."""
    rows, cols = _window(size, window)
    digest = hashlib.sha1(_code_digest().encode())
    for matrix in (camera_matrix, source_matrix, lens.dist_coeffs()):
        matrix = np.ascontiguousarray(matrix)
        digest.update(f"{matrix.dtype.str}{matrix.shape}".encode())
        digest.update(matrix.tobytes())
    places = (rows.start, rows.stop, cols.start, cols.stop)
    digest.update(repr((tuple(map(int, source_size)), tuple(map(int, places)))).encode())
    return digest.hexdigest()


@functools.cache
def _code_digest() -> str:
    """Digest of the code the maps come from, read once a process."""
    digest = hashlib.sha1(Path(__file__).read_bytes())
    versions = (cv2.__version__, np.__version__, cv2.getCPUFeaturesLine(), platform.machine())
    digest.update(repr((versions, _ITER_CRITERIA)).encode())
    return digest.hexdigest()


def _window(size: tuple[int, int], window: tuple[slice, slice] | None) -> tuple[slice, slice]:
    """The (rows, columns) of a distorted image of `size` (width, height) a window produces."""
    return (slice(0, int(size[1])), slice(0, int(size[0]))) if window is None else window


class LensDistorter:
    """Turns pinhole renders into the distorted images of a camera with `lens`.

    Args:
        camera_matrix: (3, 3) intrinsics of the distorted output [px].
        lens: The lens's distortion coefficients.
        size: Output (width, height) [px].
        source_matrix: (3, 3) intrinsics of the pinhole render [px].
        source_size: Pinhole render (width, height) [px].
        window: (rows, columns) slices of the distorted image to produce (default: all of
            it); the output is then that window.
        maps: `distortion_maps` of these arguments, made earlier (a cache's); None: made now.
    """

    def __init__(
        self,
        camera_matrix: np.ndarray,
        lens: LensModel,
        size: tuple[int, int],
        source_matrix: np.ndarray,
        source_size: tuple[int, int],
        window: tuple[slice, slice] | None = None,
        maps: tuple[np.ndarray, np.ndarray] | None = None,
    ):
        width, height = size
        if width < 16 or height < 16:
            raise PerceptionInputError("size", "width and height >= 16 px", size)
        self.size = (int(width), int(height))
        self.source_size = (int(source_size[0]), int(source_size[1]))
        if maps is None:
            maps = distortion_maps(camera_matrix, lens, size, source_matrix, source_size, window)
        rows, cols = _window(size, window)
        shape = (rows.stop - rows.start, cols.stop - cols.start)
        map1, map2 = maps
        fits = map1.shape == (*shape, 2) and map2.shape == shape
        if not fits or map1.dtype != np.int16 or map2.dtype != np.uint16:
            raise PerceptionInputError("lens maps", f"CV_16SC2 maps of {shape} px", map1.shape)
        self._map1, self._map2 = map1, map2

    def apply(self, pinhole: np.ndarray, interpolation: int = cv2.INTER_LINEAR) -> np.ndarray:
        """The distorted image (height, width[, channels]) of a pinhole render.

        Colour images are interpolated; pass cv2.INTER_NEAREST for a depth map, whose values
        must not blend across an item's edge.
        """
        src_w, src_h = self.source_size
        if pinhole.shape[:2] != (src_h, src_w):
            raise PerceptionInputError(
                "pinhole image shape", f"({src_h}, {src_w}, channels)", pinhole.shape
            )
        return cv2.remap(
            pinhole, self._map1, self._map2, interpolation, borderMode=cv2.BORDER_CONSTANT
        )
