"""The depth error of a stereo camera of the ZED class, applied to the renderer's exact depth.

A stereo camera measures disparity, and depth is focal length times baseline over disparity, so
a disparity error of a fraction of a pixel becomes a depth error that grows with the square of
the range. Block matching averages over a window of pixels, so neighbouring pixels err
together (a smooth, correlated error) on top of a per-pixel part. Where the depth jumps (an
item's edge against the belt) the matcher sees different things in the two images and returns
no depth: stereo depth maps have holes along edges. The model:

    z_measured = z + sigma(z) * (sqrt(1 - w) * smooth + sqrt(w) * white),
    sigma(z) = relative_error * z * max(1, z / reference_range_m),

with `smooth` unit-variance Gaussian noise blurred over `correlation_px`, `white` independent per
pixel, and invalid depth (NaN, as the ZED SDK reports it) at a share `edge_hole_share` of the
pixels within one pixel of a depth step larger than `edge_step_m`. The camera looks at the belt
from 0.75 m, so by default the error there is 1 % of the range (7.5 mm, one sigma): the ZED 2's
datasheet states < 1 % up to 3 m and < 5 % up to 15 m; we take the bound, not the typical case.
Item tops are closer and err a little less; nothing on the belt is exact to better than a
centimetre, so a 2 mm sheet cannot be told from the belt by depth alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import cv2
import numpy as np

from sim.errors import InvalidInput

_KERNEL = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class StereoDepthNoise:
    """Depth error model of a stereo camera (see the module docstring).

    Attributes:
        relative_error: One-sigma error as a share of the range at and below the reference
            range.
        reference_range_m: Range beyond which the error grows with the square of the range [m].
        white_share: Share of the error's variance that is independent per pixel.
        correlation_px: Standard deviation of the blur that correlates the rest [px].
        edge_step_m: A depth step larger than this between neighbouring pixels is an edge [m].
        edge_hole_share: Share of the pixels at an edge that get no depth.
    """

    relative_error: float = 0.01
    reference_range_m: float = 0.75
    white_share: float = 0.3
    correlation_px: float = 2.0
    edge_step_m: float = 0.01
    edge_hole_share: float = 0.6

    def __post_init__(self) -> None:
        if not 0.0 <= self.relative_error <= 0.2:
            raise InvalidInput("depth_noise.relative_error", "0..0.2", self.relative_error)
        if not 0.05 <= self.reference_range_m <= 20.0:
            got = self.reference_range_m
            raise InvalidInput("depth_noise.reference_range_m", "0.05..20 m", got)
        if not 0.0 <= self.white_share <= 1.0:
            raise InvalidInput("depth_noise.white_share", "0..1", self.white_share)
        if not 0.0 < self.correlation_px <= 20.0:
            raise InvalidInput("depth_noise.correlation_px", "(0, 20] px", self.correlation_px)
        if not self.edge_step_m > 0.0:
            raise InvalidInput("depth_noise.edge_step_m", "> 0 m", self.edge_step_m)
        if not 0.0 <= self.edge_hole_share <= 1.0:
            raise InvalidInput("depth_noise.edge_hole_share", "0..1", self.edge_hole_share)

    def sigma(self, z: np.ndarray) -> np.ndarray:
        """One-sigma depth error [m] at range `z` [m]."""
        z = np.asarray(z, dtype=np.float32)
        return self.relative_error * z * np.maximum(1.0, z / self.reference_range_m)

    def apply(self, depth: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The measured depth map (float32 [m], NaN where there is none) of exact `depth` [m].

        Args:
            depth: (rows, cols) exact depth along the optical axis [m]; non-positive or
                non-finite values are already invalid and stay NaN.
            rng: The camera's random stream (seeded by the episode).
        """
        z = np.asarray(depth, dtype=np.float32)
        valid = np.isfinite(z) & (z > 0.0)
        smooth = rng.standard_normal(z.shape, dtype=np.float32)
        # float32 in, float32 out (OpenCV's stubs say any number type).
        smooth = cast(np.ndarray, cv2.GaussianBlur(smooth, (0, 0), self.correlation_px))
        # A Gaussian blur of unit white noise of sigma s has variance 1 / (4 pi s^2).
        smooth *= np.float32(2.0 * np.sqrt(np.pi) * self.correlation_px)
        white = rng.standard_normal(z.shape, dtype=np.float32)
        w = self.white_share
        error = np.sqrt(1.0 - w) * smooth + np.sqrt(w) * white
        filled = np.where(valid, z, 0.0).astype(np.float32)  # float32 already: a copy
        out = z + self.sigma(filled) * error
        step = cv2.dilate(filled, _KERNEL) - cv2.erode(filled, _KERNEL)
        edge = step > self.edge_step_m
        holes = edge & (rng.random(z.shape, dtype=np.float32) < self.edge_hole_share)
        out[holes | ~valid] = np.nan
        return out.astype(np.float32)


ZED_CLASS = StereoDepthNoise()
"""The default: a ZED-class stereo camera at the bound of its datasheet's accuracy."""
