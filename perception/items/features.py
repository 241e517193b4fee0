"""What the camera shows of one item, as a fixed vector of numbers for a classifier.

An item found by the camera (`perception.items.blobs`) is a set of top-down pixels, each with
its belt position, its height above the belt from the stereo depth and its colour. The
features describe, in SI units or shares:

- the footprint: area, the sides of its smallest enclosing rectangle, how much of that
  rectangle it fills (a sheet fills it, a standing can covers pi/4 of it, a lying bottle in
  between), its elongation;
- its height profile: robust quantiles of the noisy heights (a sheet stays within the depth
  noise of the belt, a crumpled sheet rises a few centimetres, a lying can shows a round ridge,
  a standing can a flat top), the share of pixels above 1, 3 and 6 cm, and how flat the top is;
- its ends: the width and the height of its outermost `END_ZONE_M` at either end of its long
  axis, against its width and its height, at the rounder end (a lying bottle's ends are
  half-spheres, narrower and lower than its middle; a lying can's are flat discs, as wide and as
  high: of the two ends, the rounder is taken, since a neighbour hiding one end cuts it square);
- its colour: mean RGB, mean and spread of saturation and brightness, the shares of pixels in
  six hue bands among the coloured pixels, of bright grey (white), of dim grey (clear plastic
  over the black belt), of near-white highlights (specular metal), and the spread of hue (a
  printed label in a second colour).

The function is pure: arrays in, a vector out. Item pixels come on a 2 mm raster, so a few
dozen pixels are enough for every feature.
"""

from __future__ import annotations

import cv2
import numpy as np

from perception.errors import PerceptionInputError

HUE_EDGES_DEG = (0.0, 16.0, 50.0, 80.0, 170.0, 265.0, 320.0, 360.0)
"""Hue bands [deg] of the colour shares (red, brown/orange, yellow, green, blue, purple, red)."""
END_ZONE_M = 0.01
"""Length of an item's end, from its outermost pixel along its long axis [m]."""
COLOURED_MIN_SATURATION = 60
"""A pixel with at least this saturation (0..255) has a hue worth counting."""
FEATURE_NAMES = (
    "area_m2",
    "length_m",
    "width_m",
    "fill",
    "elongation",
    "height_p50_m",
    "height_p90_m",
    "height_p25_m",
    "height_std_m",
    "above_1cm",
    "above_3cm",
    "above_6cm",
    "top_flatness",
    "end_width",
    "end_height",
    "mean_r",
    "mean_g",
    "mean_b",
    "mean_saturation",
    "std_saturation",
    "mean_value",
    "std_value",
    *(f"hue_{i}" for i in range(len(HUE_EDGES_DEG) - 1)),
    "coloured",
    "bright_grey",
    "dim_grey",
    "highlight",
    "hue_spread",
)
N_FEATURES = len(FEATURE_NAMES)


def item_features(
    b: np.ndarray, y: np.ndarray, height: np.ndarray, rgb: np.ndarray, pixel_m: float = 0.002
) -> np.ndarray:
    """The feature vector (N_FEATURES,) float64 of one item (order of FEATURE_NAMES).

    Args:
        b: (N,) belt coordinates of the item's pixels [m].
        y: (N,) lateral positions [m].
        height: (N,) heights above the belt [m] (from the depth map; noisy).
        rgb: (N, 3) uint8 colours as the frame shows them.
        pixel_m: Side of a top-down pixel [m].

    Raises:
        PerceptionInputError: Arrays of different lengths or no pixels.
    """
    b, y = np.asarray(b, np.float64), np.asarray(y, np.float64)
    height = np.asarray(height, np.float64)
    rgb = np.asarray(rgb, np.uint8).reshape(-1, 3)
    n = b.size
    if n == 0 or not (y.size == n and height.size == n and len(rgb) == n):
        raise PerceptionInputError("item pixels", "N >= 1 of each: b, y, height, rgb", n)
    area = n * pixel_m * pixel_m
    points = np.stack([b, y], axis=1).astype(np.float32)
    (_, _), (side_a, side_b), angle_deg = cv2.minAreaRect(points)
    length = max(side_a, side_b) + pixel_m
    width = min(side_a, side_b) + pixel_m
    p25, p50, p90 = np.percentile(height, (25, 50, 90))
    top = height >= 0.8 * p90
    flatness = float(np.std(height[top])) / max(p90, 0.005)
    end_width, end_height = _rounder_end(b, y, height, side_a >= side_b, angle_deg, width, p90)
    hsv = cv2.cvtColor(rgb.reshape(-1, 1, 3), cv2.COLOR_RGB2HSV_FULL).reshape(-1, 3)
    hue = hsv[:, 0].astype(np.float64) * (360.0 / 256.0)
    sat = hsv[:, 1].astype(np.float64)
    val = hsv[:, 2].astype(np.float64)
    coloured = sat >= COLOURED_MIN_SATURATION
    n_col = int(coloured.sum())
    bands = np.histogram(hue[coloured], bins=HUE_EDGES_DEG)[0] / max(n_col, 1)
    grey = ~coloured
    if n_col >= 2:
        angles = np.radians(hue[coloured])
        resultant = np.hypot(np.cos(angles).mean(), np.sin(angles).mean())
        hue_spread = float(np.sqrt(max(-2.0 * np.log(max(resultant, 1e-9)), 0.0)))
    else:
        hue_spread = 0.0
    return np.array(
        [
            area,
            length,
            width,
            area / (length * width),
            length / width,
            p50,
            p90,
            p25,
            float(np.std(height)),
            float(np.mean(height > 0.01)),
            float(np.mean(height > 0.03)),
            float(np.mean(height > 0.06)),
            flatness,
            end_width,
            end_height,
            *(rgb.mean(axis=0) / 255.0),
            sat.mean() / 255.0,
            sat.std() / 255.0,
            val.mean() / 255.0,
            val.std() / 255.0,
            *bands,
            n_col / n,
            float(np.mean(grey & (val >= 200))),
            float(np.mean(grey & (val < 200))),
            float(np.mean((val >= 250) & (sat < 40))),
            hue_spread,
        ]
    )


def _rounder_end(
    b: np.ndarray,
    y: np.ndarray,
    height: np.ndarray,
    first_side_long: bool,
    angle_deg: float,
    width: float,
    height_p90: float,
) -> tuple[float, float]:
    """(width share, height share) of the rounder of an item's two ends.

    An end is the pixels within `END_ZONE_M` of the item's outermost pixel along its long axis
    (the direction of the longer side of its smallest enclosing rectangle, at `angle_deg` from
    b for its first side). Its width is its pixels' lateral extent across that axis over the
    item's `width`; its height, their median height over the item's 90th percentile (`height_p90`,
    at least 5 mm). The end with the smaller product of the two is returned.
    """
    angle = np.radians(angle_deg if first_side_long else angle_deg + 90.0)
    along = b * np.cos(angle) + y * np.sin(angle)
    across = -b * np.sin(angle) + y * np.cos(angle)
    best = (1.0, 1.0)
    for zone in (along <= along.min() + END_ZONE_M, along >= along.max() - END_ZONE_M):
        extent = float(np.ptp(across[zone])) / max(width, 1e-9)
        rise = float(np.median(height[zone])) / max(height_p90, 0.005)
        end = (min(extent, 1.0), min(rise, 1.5))
        if end[0] * end[1] < best[0] * best[1]:
            best = end
    return best
