"""The camera pipeline: raw frame -> one grid row of observation codes and item pixels.

    frame (distorted) --remap--> top-down belt image (undistorted + rectified in one step)
          --> band of row k --> colour labels --> 5 cell codes + item pixels
    frame + depth --> 3-D item points --> top-down footprints (orthographic) --> same coding

`CameraPipeline` is what the episode runner calls once per observation period. It locates the
belt from the corner markers on its first frame (or on `locate`), then checks on every frame
that the frame is usable: right shape, not black, markers where they were. A camera reading out
only the window its row's band is seen in (`observe_window`) has its markers, outside that
window, checked on the whole frames it reads now and then. An unusable frame raises
PerceptionError; the runner logs it and marks the row unobserved.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from perception.camera.calibration import CameraCalibration
from perception.camera.depth_footprint import BELT_EDGE_M, FootprintMapper
from perception.camera.grid import BeltGrid
from perception.camera.observe import BELT, CellObservation, ColourRules, code_cells
from perception.camera.rectify import (
    BeltRectifier,
    BeltView,
    TopDownRaster,
    colour_mask,
    locate_belt,
)
from perception.errors import PerceptionError, PerceptionInputError

_MARKER_PATCH_PX = 4
BAND_MARGIN_M = 0.015
"""Belt beyond each end of a row's band whose footprints are found with it [m]: what the
filters at the band's edges read (the 5-pixel median, the 3-pixel closing, an item's brightest
pixel for its rim)."""
_KERNEL = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class RowObservation:
    """One observation period's row.

    Attributes:
        row: Row index k (t_k = k T).
        t: Time of the frame [s].
        codes: (n_stripes,) observation codes 1..19, stripe 0 on the -y side.
        cells: Per stripe, the cell's observation (fraction, colour, item pixels).
    """

    row: int
    t: float
    codes: np.ndarray
    cells: tuple[CellObservation, ...]


class CameraPipeline:
    """Frames of the belt camera -> rows of observation codes.

    Args:
        calibration: The camera's intrinsics and distortion (`sortsim calibrate`).
        grid: The belt grid (stripes, camera line, observation period).
        marker_world: (N >= 4, 3) world centres of the corner markers [m] (from the cell's MJCF).
        marker_colours: (N, 3) their colours [0..1].
        resolution_m: Side of a top-down pixel [m].
        plane_z: Height above the belt of the rectified plane of frames without depth [m].
        max_pitch_m: Longest row the pipeline must see (top belt speed x period) [m].
        edge_margin_m: The belt's outer strips whose pixels are not items [m]
            (`perception.camera.depth_footprint.BELT_EDGE_M` by default).
    """

    def __init__(
        self,
        calibration: CameraCalibration,
        grid: BeltGrid,
        marker_world: np.ndarray,
        marker_colours: np.ndarray,
        resolution_m: float = 0.002,
        plane_z: float = 0.0,
        max_pitch_m: float = 0.3,
        rules: ColourRules | None = None,
        edge_margin_m: float = BELT_EDGE_M,
    ):
        self.calibration = calibration
        self.edge_margin_m = float(edge_margin_m)
        self.grid = grid
        self.marker_world = np.asarray(marker_world, dtype=np.float64)
        self.marker_colours = np.asarray(marker_colours, dtype=np.float64)
        if self.marker_colours.shape != self.marker_world.shape:
            raise PerceptionInputError(
                "marker_colours", f"shape {self.marker_world.shape}", self.marker_colours.shape
            )
        half = 0.5 * max_pitch_m
        self.raster = TopDownRaster.covering(
            (grid.x_line - half, grid.x_line + half), (grid.y_min, grid.y_max), resolution_m
        )
        self.plane_z = plane_z
        self.max_pitch_m = max_pitch_m
        self.rules = rules or ColourRules()
        self.view: BeltView | None = None
        self.rectifier: BeltRectifier | None = None
        self.mapper: FootprintMapper | None = None
        self._band_mappers: dict[float, FootprintMapper] = {}
        self._marker_px: np.ndarray | None = None

    def check_frame(self, frame: np.ndarray) -> None:
        """Raises PerceptionError for a frame of the wrong shape, dtype, or an all-dark one."""
        width, height = self.calibration.image_size
        if not isinstance(frame, np.ndarray) or frame.shape != (height, width, 3):
            shape = getattr(frame, "shape", type(frame).__name__)
            raise PerceptionError(f"frame shape {shape}, expected ({height}, {width}, 3)")
        if frame.dtype != np.uint8:
            raise PerceptionError(f"frame dtype {frame.dtype}, expected uint8")
        if int(frame[::8, ::8].max()) < 20:
            raise PerceptionError("frame is all black (camera or lighting off)")

    def locate(self, frame: np.ndarray) -> BeltView:
        """Solves the camera's pose from the markers in `frame`; builds rectifier and mapper."""
        self.check_frame(frame)
        view = locate_belt(frame, self.calibration, self.marker_world, self.marker_colours)
        self.rectifier = BeltRectifier(view, self.raster, self.plane_z)
        self.mapper = FootprintMapper(view, self.raster, edge_margin_m=self.edge_margin_m)
        self._band_mappers = {}
        self.view = view
        self._marker_px = np.round(view.project(self.marker_world)).astype(int)
        return view

    def band_mapper(self, belt_speed: float) -> FootprintMapper:
        """The footprint mapper of the rows the frames of belt speed `belt_speed` [m/s] are
        coded on: the row's band (`BeltGrid.band`, centred on the camera line) and
        `BAND_MARGIN_M` either side, so that each frame's item pixels are found where its row
        is, and only there (made once per speed; needs a located belt)."""
        if self.view is None:
            raise PerceptionError("the belt is not located yet (no frame seen)")
        key = float(belt_speed)
        mapper = self._band_mappers.get(key)
        if mapper is None:
            x_lo, x_hi = self.grid.band(belt_speed)
            raster = self.raster
            x_min, x_max = raster.x_min, raster.x_min + raster.shape[0] * raster.resolution_m
            x_range = (max(x_lo - BAND_MARGIN_M, x_min), min(x_hi + BAND_MARGIN_M, x_max))
            mapper = self._band_mappers[key] = FootprintMapper(
                self.view, raster, x_range=x_range, edge_margin_m=self.edge_margin_m
            )
        return mapper

    def check(self, frame: np.ndarray) -> None:
        """Locates the belt on first use, then checks the frame and the markers' places."""
        if self.view is None:
            self.locate(frame)
            return
        self.check_frame(frame)
        assert self._marker_px is not None  # located together with the view
        r = _MARKER_PATCH_PX
        for index, (u, v) in enumerate(self._marker_px):
            patch = frame[max(v - r, 0) : v + r + 1, max(u - r, 0) : u + r + 1]
            if patch.size == 0 or colour_mask(patch, self.marker_colours[index]).mean() < 0.5:
                raise PerceptionError(f"marker {index} not seen where it was (pixel {u}, {v})")

    def cell_corners_image(self, belt_speed: float, t: float | None = None) -> np.ndarray:
        """(n_stripes, 4, 2) raw-frame pixels of the current row's cell corners (see
        `BeltGrid.cell_corners`), e.g. to draw the grid on a frame; needs a located belt."""
        if self.view is None:
            raise PerceptionError("the belt is not located yet (no frame seen)")
        corners = self.grid.cell_corners(belt_speed, t)
        return self.view.project(corners.reshape(-1, 3)).reshape(*corners.shape[:2], 2)

    def rectify(self, frame: np.ndarray) -> np.ndarray:
        """The top-down image of the belt plane (`plane_z`) of a raw frame."""
        self.check(frame)
        assert self.rectifier is not None  # made when the belt was located
        return self.rectifier.rectify(frame)

    def observe(
        self, frame: np.ndarray, belt_speed: float, t: float, depth: np.ndarray | None = None
    ) -> RowObservation:
        """The row of codes of the frame taken at time `t` [s] at belt speed `belt_speed` [m/s].

        With a depth map (registered to the frame, [m] along the optical axis) the items'
        footprints are found in 3-D (`FootprintMapper`, over the row's band: `band_mapper`);
        without, the frame is rectified onto the belt plane and tall items look larger than
        they lie. Item pixel coordinates are belt-plane positions at the row's time t_k = k T;
        with depth, each cell also carries its item pixels' heights above the belt [m] and
        colours (RGB).

        Raises:
            PerceptionError: The frame cannot be used (shape, all black, markers not seen).
        """
        self._check_speed(belt_speed)
        if depth is None:
            return self.code_row(self.rectify(frame), belt_speed, t)
        self.check(frame)
        mapper = self.band_mapper(belt_speed)
        labels, height, colour = mapper.footprint_and_height(frame, depth, self.rules)
        return self.row_observation(labels, belt_speed, t, height, colour)

    def observe_window(
        self, crop: np.ndarray, depth: np.ndarray, belt_speed: float, t: float
    ) -> RowObservation:
        """`observe` of a camera reading out only the window its footprints use
        (`FootprintMapper.roi`): the window of the frame taken at time `t` [s] and of its depth
        map. The belt must be located (`check` on a whole frame); the markers lie outside the
        window and are checked on whole frames only.

        Raises:
            PerceptionError: The belt is not located, or the window cannot be used (shape,
                dtype, all black).
        """
        self._check_speed(belt_speed)
        if self.view is None:
            raise PerceptionError("the belt is not located yet (no whole frame seen)")
        if not isinstance(crop, np.ndarray) or crop.dtype != np.uint8:
            raise PerceptionError(f"window dtype {getattr(crop, 'dtype', None)}, expected uint8")
        if crop.size == 0 or int(crop[::8, ::8].max()) < 20:
            raise PerceptionError("window is all black (camera or lighting off)")
        mapper = self.band_mapper(belt_speed)
        labels, height, colour = mapper.window_footprint_and_height(crop, depth, self.rules)
        return self.row_observation(labels, belt_speed, t, height, colour)

    def code_row(self, top: np.ndarray, belt_speed: float, t: float) -> RowObservation:
        """The row of codes of a top-down image (`rectify`) taken at time `t` [s]."""
        self._check_speed(belt_speed)
        if top.shape[:2] != self.raster.shape:
            raise PerceptionInputError("top-down image", f"shape {self.raster.shape}", top.shape)
        start, stop = self._band_rows(belt_speed, t)
        labels = np.full(self.raster.shape, BELT, dtype=np.int8)
        band = self.rules.classify(top[start:stop])
        # One-pixel lines are the belt's edge seen through antialiasing, not items.
        solid = cv2.morphologyEx((band != BELT).astype(np.uint8), cv2.MORPH_OPEN, _KERNEL)
        band[solid == 0] = BELT
        labels[start:stop] = band
        return self.row_observation(labels, belt_speed, t)

    def _check_speed(self, belt_speed: float) -> None:
        pitch = self.grid.row_pitch(belt_speed)
        if pitch > self.max_pitch_m:
            raise PerceptionInputError(
                "belt speed", f"at most {self.max_pitch_m / self.grid.period_s} m/s", belt_speed
            )

    def _band_rows(self, belt_speed: float, t: float) -> tuple[int, int]:
        return self.raster.rows_of(*self.grid.band(belt_speed, t))

    def row_observation(
        self,
        labels: np.ndarray,
        belt_speed: float,
        t: float,
        height: np.ndarray | None = None,
        colour: np.ndarray | None = None,
    ) -> RowObservation:
        """The row of codes of a label raster (`labels`, the belt band of time `t` [s] filled
        in), each cell with its pixels' heights [m] and colours when given."""
        raster = self.raster
        row_slice = self._band_rows(belt_speed, t)
        edges = self.grid.stripe_edges()
        col_slices = [raster.cols_of(edges[j], edges[j + 1]) for j in range(len(edges) - 1)]
        k = self.grid.row_of_time(t)
        back = belt_speed * (t - k * self.grid.period_s)
        cells = []
        for code, fraction, name, rows, cols in code_cells(labels, row_slice, col_slices):
            xy = raster.pixel_to_world(rows, cols)
            xy[:, 0] -= back
            heights = None if height is None else height[rows, cols]
            rgb = None if colour is None else colour[rows, cols]
            cells.append(CellObservation(code, fraction, name, xy, heights, rgb))
        codes = np.array([c.code for c in cells], dtype=np.int64)
        return RowObservation(k, float(t), codes, tuple(cells))
