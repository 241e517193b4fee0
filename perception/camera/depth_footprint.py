"""Item footprints on the belt from a frame and its registered depth map.

A camera 0.75 m above the belt sees tall items in perspective: a can standing near the belt's
edge covers, on the belt-plane image, its footprint plus its side wall and a top shifted
outwards by centimetres, which inflates the covered fraction of its cells and spills into
empty neighbours. A stereo camera like the ZED also gives each pixel's depth; with the
calibrated lens and the marker-solved pose every item pixel becomes a 3-D point, and dropping
it straight down onto the belt gives the item's true footprint (an orthographic top view).

`FootprintMapper` does that for the pixels that can see the grid's region: colour labels from
`ColourRules` on the raw frame, 3-D points from depth, splatted onto a metric top-down grid
whose small holes (grid cells no pixel fell in) are closed morphologically. The points' heights
above the belt come along on the same grid (`footprint_and_height`): two items that touch on
the belt are told apart by the step in height between them (`perception.items.split`).
"""

from __future__ import annotations

import cv2
import numpy as np

from perception.camera.observe import BELT, ColourRules
from perception.camera.rectify import BeltView, TopDownRaster
from perception.errors import PerceptionError, PerceptionInputError

BELT_EDGE_M = 0.004
"""Pixels seeing the belt's outer 4 mm are not items: the belt's edge meets the rails there,
and its antialiased line would pass for a clear item. The flow keeps items 5 mm inside. (A
mapper's `edge_margin_m`; a wider belt's rails, seen more obliquely, need more.)"""
_ITEM_EDGE_STEP_M = 0.02
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 1e-9)
_KERNEL = np.ones((3, 3), np.uint8)


def _solid(image: np.ndarray, item: np.ndarray, rim_fraction: float) -> np.ndarray:
    """Item pixels at least `rim_fraction` as bright as their blob's brightest pixel."""
    # The brightest channel, channel by channel (a reduction over numpy's last, 3-long axis
    # costs twenty times more).
    value = np.maximum(np.maximum(image[..., 0], image[..., 1]), image[..., 2])
    count, blobs = cv2.connectedComponents(item.astype(np.uint8), connectivity=8)
    peak = np.zeros(count, dtype=np.uint8)
    np.maximum.at(peak, blobs[item], value[item])
    return item & (value >= (rim_fraction * peak)[blobs])


def _copy_where(target: np.ndarray, source: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """`target[mask] = source[mask]` for images (rows, cols[, channels]) and a (rows, cols)
    bool mask, through OpenCV's masked copy (numpy's boolean index over a colour image's two
    first axes costs some ten times more); returns `target`, written in place."""
    return cv2.copyTo(source, mask.view(np.uint8), target)


class FootprintMapper:
    """Raw frame + depth -> top-down colour labels of item footprints.

    Args:
        raster: The top-down raster (`TopDownRaster.covering`).
        max_height_m: Tallest item [m]; bounds the frame region that can see the raster.
        min_height_m: Item pixels stand at least this high above the belt [m].
        rim_fraction: Pixels dimmer than this fraction of their item's brightest pixel are its
            antialiased rim (partly belt) or its shaded side, and left out.
        smooth_px: Side of the median filter over the depth's heights [px] (a stereo camera's
            depth is noisy); 1: none.
        x_range: (x_lo, x_hi) [m] of the belt the footprints are wanted over, inside the
            raster's (default: all of it); the frame window `roi` is what can see it, and
            the raster's rows beyond it stay belt.
        edge_margin_m: Pixels seeing the raster's outer strips this wide across the belt are
            not items [m] (`BELT_EDGE_M`).
    """

    def __init__(
        self,
        view: BeltView,
        raster: TopDownRaster,
        max_height_m: float = 0.15,
        min_height_m: float = 0.0008,
        rim_fraction: float = 0.35,
        smooth_px: int = 5,
        x_range: tuple[float, float] | None = None,
        edge_margin_m: float = BELT_EDGE_M,
    ):
        if not 0.0 <= rim_fraction < 1.0:
            raise PerceptionInputError("rim_fraction", "[0, 1)", rim_fraction)
        if not 0.0 < min_height_m < max_height_m <= 1.0:
            raise PerceptionInputError(
                "min_height_m, max_height_m", "0 < min < max <= 1 m", (min_height_m, max_height_m)
            )
        if smooth_px not in (1, 3, 5):
            raise PerceptionInputError("smooth_px", "1, 3 or 5 (a median filter's side)", smooth_px)
        if not (np.isfinite(edge_margin_m) and 0.0 <= edge_margin_m < 0.1):
            raise PerceptionInputError("edge_margin_m", "0 <= margin < 0.1 m", edge_margin_m)
        self.edge_margin_m = float(edge_margin_m)
        self.smooth_px = smooth_px
        self.min_height_m = float(min_height_m)
        self.rim_fraction = float(rim_fraction)
        self.raster = raster
        raster_x = (raster.x_min, raster.x_min + raster.shape[0] * raster.resolution_m)
        if x_range is None:
            x_range = raster_x
        elif not raster_x[0] <= x_range[0] < x_range[1] <= raster_x[1]:
            raise PerceptionInputError("x_range", f"an interval inside {raster_x} m", x_range)
        y_range = (raster.y_min, raster.y_min + raster.shape[1] * raster.resolution_m)
        width, height = view.calibration.image_size
        # Frame rows/columns that can see the region, at any height up to the tallest item.
        xs, ys, zs = np.meshgrid(x_range, y_range, (0.0, max_height_m), indexing="ij")
        box = view.project(np.stack([xs.ravel(), ys.ravel(), zs.ravel()], 1))
        u0, v0 = np.floor(box.min(axis=0)).astype(int) - 2
        u1, v1 = np.ceil(box.max(axis=0)).astype(int) + 3
        self.roi = (slice(max(v0, 0), min(v1, height)), slice(max(u0, 0), min(u1, width)))
        rows = np.arange(height)[self.roi[0]]
        cols = np.arange(width)[self.roi[1]]
        uu, vv = np.meshgrid(cols.astype(np.float64), rows.astype(np.float64))
        cal = view.calibration
        norm = cv2.undistortPoints(
            np.stack([uu.ravel(), vv.ravel()], 1).reshape(-1, 1, 2),
            cal.camera_matrix,
            cal.dist_coeffs,
            None,
            None,
            None,
            _UNDISTORT_CRITERIA,
        ).reshape(-1, 2)
        rot, _ = cv2.Rodrigues(view.rvec)
        # A pixel at depth d (along the optical axis) sees origin + d * direction.
        self._origin = view.camera_position()
        self._direction = (np.c_[norm, np.ones(len(norm))] @ rot).astype(np.float32)

    def footprint(self, frame: np.ndarray, depth: np.ndarray, rules: ColourRules) -> np.ndarray:
        """Colour labels (rows, cols) int8 of the top-down grid; BELT (-1) where no item lies.

        Raises:
            PerceptionError: The depth map does not match the frame or holds no valid depth.
        """
        return self.footprint_and_height(frame, depth, rules)[0]

    def footprint_and_height(
        self, frame: np.ndarray, depth: np.ndarray, rules: ColourRules
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Colour labels (as `footprint`), the height above the belt (rows, cols) float32 [m]
        of the item surface seen over each top-down pixel (0 where no item lies) and its RGB
        (rows, cols, 3) uint8 as the frame shows it (0 where no item lies).

        Raises:
            PerceptionError: The depth map does not match the frame or holds no valid depth.
        """
        if depth is None or depth.shape != frame.shape[:2]:
            shape = None if depth is None else depth.shape
            raise PerceptionError(f"depth map shape {shape}, expected {frame.shape[:2]}")
        return self.window_footprint_and_height(frame[self.roi], depth[self.roi], rules)

    @property
    def window_shape(self) -> tuple[int, int]:
        """(rows, columns) of the frame window `roi` [px]."""
        return (self.roi[0].stop - self.roi[0].start, self.roi[1].stop - self.roi[1].start)

    def window_footprint_and_height(
        self, crop: np.ndarray, depth: np.ndarray, rules: ColourRules
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`footprint_and_height` of the window `roi` of a frame and of its depth map: what a
        camera reading out only that window (`sim.cell.camera.CameraWindow`) delivers.

        Raises:
            PerceptionError: The crops are not of the window's shape, or hold no valid depth.
        """
        if crop.shape[:2] != self.window_shape or depth is None or depth.shape != crop.shape[:2]:
            shape = (crop.shape[:2], None if depth is None else depth.shape)
            raise PerceptionError(f"window shapes {shape}, expected {self.window_shape}")
        height, has_depth = self._heights(depth)
        labels = self._labels(crop, rules, height, has_depth)
        has_depth = has_depth.ravel()
        belt = np.flatnonzero(has_depth & (labels == BELT))[::4]
        if len(belt) < 100:
            raise PerceptionError("depth map: too few valid belt pixels")
        # The belt's height as this camera measures it (a pose error shifts it by a millimetre
        # or so); item pixels stand above it.
        flat = height.ravel()
        belt_z = float(np.median(flat[belt]))
        floor = belt_z + self.min_height_m
        # A pixel on an item's rim blends the item's colour with the belt behind it and may
        # carry the belt's depth: it is placed at the highest surface seen around it, on its
        # own ray, which puts it on the item's top edge. An item pixel (by colour) measured at
        # the belt's height is a thin sheet seen through the depth noise: it lies on the floor.
        around = cv2.dilate(np.where(has_depth.reshape(height.shape), height, -1.0), _KERNEL)
        top_z = np.maximum(np.where(flat > floor, flat, around.ravel()), floor)
        item = np.flatnonzero(has_depth & (labels != BELT))
        return self._splat(crop, labels, item, top_z, belt_z)

    def _heights(self, depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(height (rows, cols) float32 [m, world z] of the surface each window pixel sees,
        smoothed, 0 where none; which pixels have a depth) of the window's depth map."""
        z = np.asarray(depth, dtype=np.float32).copy()
        valid = np.isfinite(z) & (z > 0.0)
        z[~valid] = 0.0
        direction = self._direction
        own_height = self._origin[2] + z * direction[:, 2].reshape(z.shape)
        # A stereo camera's depth is noisy (a centimetre at this range) and has holes at
        # edges: a hole takes the highest depth around it (edges are where items rise), then
        # a median over a small window drops the noise and keeps the edges.
        filled = np.where(valid, own_height, -1.0).astype(np.float32)
        for _ in range(2):
            filled = np.where(filled > -0.5, filled, cv2.dilate(filled, _KERNEL))
        has_depth = filled > -0.5
        height = cv2.medianBlur(filled, self.smooth_px) if self.smooth_px > 1 else filled
        return np.where(has_depth, height, 0.0).astype(np.float32), has_depth

    def _labels(
        self, crop: np.ndarray, rules: ColourRules, height: np.ndarray, has_depth: np.ndarray
    ) -> np.ndarray:
        """Colour labels (rows * cols,) int8 of the window's pixels, BELT for the belt, its
        rails and the antialiased rims of items."""
        shape = height.shape
        direction = self._direction
        y = self._origin[1] + (height - self._origin[2]) / direction[:, 2].reshape(
            shape
        ) * direction[:, 1].reshape(shape)
        # Only pixels that see the belt (or what lies on it) can be items: not its rails.
        raster = self.raster
        y_lo = raster.y_min + self.edge_margin_m
        y_hi = raster.y_min + raster.shape[1] * raster.resolution_m - self.edge_margin_m
        # Two items that touch in the image are told apart by the jump in height between them.
        step = cv2.dilate(height, _KERNEL) - cv2.erode(height, _KERNEL)
        where = has_depth & (y >= y_lo) & (y <= y_hi)
        labels = rules.classify(crop, where, step < _ITEM_EDGE_STEP_M)
        labels[~_solid(crop, labels != BELT, self.rim_fraction)] = BELT
        return labels.ravel()

    def _splat(
        self,
        crop: np.ndarray,
        labels: np.ndarray,
        item: np.ndarray,
        top_z: np.ndarray,
        belt_z: float,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The item pixels `item` (flat window indices) dropped onto the top-down raster along
        their rays from their top heights `top_z` [m]: (labels, height above the belt `belt_z`
        [m], colour) of each raster pixel, its pinholes closed and one-pixel lines removed."""
        direction, raster = self._direction, self.raster
        reach = (top_z[item] - self._origin[2]) / direction[item, 2]
        points = self._origin[None, :2] + reach[:, None] * direction[item, :2]
        i = np.floor((points[:, 0] - raster.x_min) / raster.resolution_m).astype(np.int64)
        j = np.floor((points[:, 1] - raster.y_min) / raster.resolution_m).astype(np.int64)
        inside = (i >= 0) & (i < raster.shape[0]) & (j >= 0) & (j < raster.shape[1])
        i, j, item = i[inside], j[inside], item[inside]
        top = np.full(raster.shape, BELT, dtype=np.int8)
        top[i, j] = labels[item]
        height_above = np.zeros(raster.shape, dtype=np.float32)
        height_above[i, j] = top_z[item] - belt_z
        colour = np.zeros((*raster.shape, 3), dtype=np.uint8)
        colour[i, j] = crop.reshape(-1, 3)[item]
        # Close the pinholes between splatted pixels; they take a neighbour's colour and height.
        covered = (top != BELT).astype(np.uint8)
        holes = (cv2.morphologyEx(covered, cv2.MORPH_CLOSE, _KERNEL) > 0) & (covered == 0)
        if np.any(holes):
            spread = cv2.dilate((top + 1).astype(np.uint8), _KERNEL).astype(np.int8) - 1
            top[holes] = spread[holes]
            height_above[holes] = cv2.dilate(height_above, _KERNEL)[holes]
            colour = _copy_where(colour, cv2.dilate(colour, _KERNEL), holes)
        # One-pixel lines are the belt's edges seen through antialiasing, not items (a sheet's
        # pixels at the belt's height are kept, so the depth no longer rules them out).
        lines = cv2.morphologyEx((top != BELT).astype(np.uint8), cv2.MORPH_OPEN, _KERNEL) == 0
        top[lines] = BELT
        height_above[lines] = 0.0
        colour = _copy_where(colour, np.zeros_like(colour), lines)
        return top, height_above, colour
