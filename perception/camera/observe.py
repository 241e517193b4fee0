"""Observation codes of one grid row from the top-down belt image.

Items are segmented from the black belt by brightness, each item pixel gets one of the six
colour names of table 3.2 from its hue, saturation and brightness (`ColourRules`), and each cell
gets the code of its covered fraction (small / medium / large, `perception.codes`) and its
dominant colour; code 19 when under 1 % of the cell is covered.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from perception.codes import COLOURS, EMPTY_CODE, code_of_cell
from perception.errors import PerceptionInputError

BELT = -1


@dataclass(frozen=True)
class ColourRules:
    """Per-pixel colour rules on OpenCV's HSV (H in degrees 0..360, S and V 0..255).

    Hued pixels take the colour of their hue band. Greyish pixels are white or transparent by
    the item they belong to (their connected greyish blob): a white item's lit surface reaches
    full brightness, while a clear item blended with the black belt stays dimmer even at its
    highlights. Pixel by pixel, the shaded rim of a white bottle or the side wall of a white can
    would look transparent.

    Attributes:
        item_min_value: Brightness above which a pixel is an item, not the black belt.
        grey_max_saturation: Below it a pixel is greyish (white or transparent).
        white_min_value: Greyish pixels at least this bright are white.
        transparent_min_value: Greyish pixels at least this bright are lit (not shade).
        white_min_share: A greyish blob is white when at least this share of its lit pixels
            is at white brightness, else transparent.
        red_max_hue: Hues below it (or from blue_max_hue on) are red [deg].
        brown_max_hue: Hues from red_max_hue below it are brown [deg].
        green_max_hue: Hues from brown_max_hue below it are green [deg].
        blue_max_hue: Hues from green_max_hue below it are blue [deg].
    """

    item_min_value: int = 45
    grey_max_saturation: int = 90
    white_min_value: int = 235
    transparent_min_value: int = 150
    white_min_share: float = 0.25
    red_max_hue: float = 16.0
    brown_max_hue: float = 50.0
    green_max_hue: float = 170.0
    blue_max_hue: float = 265.0

    def __post_init__(self) -> None:
        for name in (
            "item_min_value",
            "grey_max_saturation",
            "white_min_value",
            "transparent_min_value",
        ):
            value = getattr(self, name)
            if not 0 <= value <= 255:
                raise PerceptionInputError(f"colour_rules.{name}", "0..255", value)
        if not self.transparent_min_value < self.white_min_value:
            raise PerceptionInputError(
                "colour_rules.transparent_min_value",
                f"< white_min_value = {self.white_min_value}",
                self.transparent_min_value,
            )
        if not 0.0 < self.white_min_share <= 1.0:
            raise PerceptionInputError(
                "colour_rules.white_min_share", "(0, 1]", self.white_min_share
            )
        if not self.red_max_hue < self.brown_max_hue < self.green_max_hue < self.blue_max_hue:
            raise PerceptionInputError(
                "colour_rules hue bounds", "red < brown < green < blue [deg]", self.blue_max_hue
            )

    def classify(
        self, image: np.ndarray, where: np.ndarray | None = None, joins: np.ndarray | None = None
    ) -> np.ndarray:
        """Colour index into COLOURS of each pixel (rows, cols) int8; BELT (-1) for the belt.

        Args:
            image: RGB image (rows, cols, 3) uint8.
            where: Optional (rows, cols) bool mask of the pixels that may be items (e.g. those
                that see the belt, not its rails); the others are BELT.
            joins: Optional (rows, cols) bool mask of the pixels that may join greyish pixels
                into one item (e.g. not on a depth edge, where two items touch in the image);
                greyish pixels outside it are white or transparent by their own brightness.
        """
        hsv = cv2.cvtColor(image, cv2.COLOR_RGB2HSV_FULL)
        sat, val = hsv[..., 1], hsv[..., 2]
        labels = np.full(image.shape[:2], BELT, dtype=np.int8)
        item = val >= self.item_min_value
        if where is not None:
            item &= where
        grey = item & (sat < self.grey_max_saturation)
        # Hue bands of the hued pixels only (the belt's pixels, most of them, have none).
        hued = np.flatnonzero(item & ~grey)
        hue = hsv[..., 0].ravel()[hued].astype(np.float32) * (360.0 / 256.0)
        bands = (
            ("red", (hue < self.red_max_hue) | (hue >= self.blue_max_hue)),
            ("brown", (hue >= self.red_max_hue) & (hue < self.brown_max_hue)),
            ("green", (hue >= self.brown_max_hue) & (hue < self.green_max_hue)),
            ("blue", (hue >= self.green_max_hue) & (hue < self.blue_max_hue)),
        )
        flat = labels.ravel()
        for name, band in bands:
            flat[hued[band]] = COLOURS.index(name)
        if np.any(grey):
            core = grey & (val >= self.white_min_value)
            lit = grey & (val >= self.transparent_min_value)
            labels[grey] = np.where(
                core[grey], COLOURS.index("white"), COLOURS.index("transparent")
            )
            linked = grey if joins is None else grey & joins
            count, blobs = cv2.connectedComponents(linked.astype(np.uint8), connectivity=8)
            n_core = np.bincount(blobs[core & linked], minlength=count)
            n_lit = np.bincount(blobs[lit & linked], minlength=count)
            white = n_core >= self.white_min_share * np.maximum(n_lit, 1)
            names = np.where(white, COLOURS.index("white"), COLOURS.index("transparent"))
            labels[linked] = names[blobs[linked]]
        return labels


@dataclass(frozen=True)
class CellObservation:
    """What the camera saw in one cell.

    Attributes:
        code: Observation code 1..19.
        fraction: Covered fraction of the cell [0..1].
        colour: Dominant colour name, or None for an empty cell.
        pixels: (N, 2) belt-plane coordinates [m] of the cell's item pixels (at the row's
            observation time).
        heights: (N,) height above the belt [m] of the item surface over each of those pixels,
            or None when the frame came without a depth map.
        rgb: (N, 3) uint8 colour of each of those pixels as the frame shows it, or None when
            the frame came without a depth map.
    """

    code: int
    fraction: float
    colour: str | None
    pixels: np.ndarray
    heights: np.ndarray | None = None
    rgb: np.ndarray | None = None


def code_cells(
    labels: np.ndarray, row_slice: tuple[int, int], col_slices: list[tuple[int, int]]
) -> list[tuple[int, float, str | None, np.ndarray, np.ndarray]]:
    """Codes of the cells of one row of a colour-label image.

    Args:
        labels: Colour labels (rows, cols) of the top-down image (`ColourRules.classify`).
        row_slice: [start, stop) rows of the band.
        col_slices: [start, stop) columns of each stripe.

    Returns:
        Per stripe: (code, fraction, colour or None, item pixel rows, item pixel columns).
    """
    out = []
    r0, r1 = row_slice
    for c0, c1 in col_slices:
        cell = labels[r0:r1, c0:c1]
        if cell.size == 0:
            raise PerceptionInputError("grid cell", "inside the rectified image", (r0, r1, c0, c1))
        rows, cols = np.nonzero(cell != BELT)
        fraction = rows.size / cell.size
        if rows.size:
            counts = np.bincount(cell[rows, cols], minlength=len(COLOURS))
            colour = COLOURS[int(np.argmax(counts))]
            code = code_of_cell(fraction, colour)
        else:
            colour, code = None, EMPTY_CODE
        if code == EMPTY_CODE:
            colour = None
        out.append((code, fraction, colour, rows + r0, cols + c0))
    return out
