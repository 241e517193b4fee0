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
    the item they belong to (a connected blob of greyish pixels): a white item has a core at
    full brightness, while a transparent one, blended with the black belt, stays dimmer even at
    its highlights; pixel by pixel, the shaded rim of a white bottle would look transparent.

    Attributes:
        item_min_value: Brightness above which a pixel is an item, not the black belt.
        grey_max_saturation: Below it a pixel is greyish (white or transparent).
        white_min_value: Brightness of a white item's core.
        white_min_core: Fraction of a greyish blob at white brightness that makes it white.
        red_max_hue: Hues below it (or from blue_max_hue on) are red [deg].
        brown_max_hue: Hues from red_max_hue below it are brown [deg].
        green_max_hue: Hues from brown_max_hue below it are green [deg].
        blue_max_hue: Hues from green_max_hue below it are blue [deg].
    """

    item_min_value: int = 45
    grey_max_saturation: int = 90
    white_min_value: int = 235
    white_min_core: float = 0.2
    red_max_hue: float = 16.0
    brown_max_hue: float = 50.0
    green_max_hue: float = 170.0
    blue_max_hue: float = 265.0

    def __post_init__(self) -> None:
        for name in ("item_min_value", "grey_max_saturation", "white_min_value"):
            value = getattr(self, name)
            if not 0 <= value <= 255:
                raise PerceptionInputError(f"colour_rules.{name}", "0..255", value)
        if not 0.0 < self.white_min_core <= 1.0:
            raise PerceptionInputError("colour_rules.white_min_core", "(0, 1]", self.white_min_core)
        if not self.red_max_hue < self.brown_max_hue < self.green_max_hue < self.blue_max_hue:
            raise PerceptionInputError(
                "colour_rules hue bounds", "red < brown < green < blue [deg]", self.blue_max_hue
            )

    def classify(self, image: np.ndarray) -> np.ndarray:
        """Colour index into COLOURS of each pixel (rows, cols) int8; BELT (-1) for the belt."""
        hsv = cv2.cvtColor(image, cv2.COLOR_RGB2HSV_FULL)
        hue = hsv[..., 0].astype(np.float32) * (360.0 / 256.0)
        sat, val = hsv[..., 1], hsv[..., 2]
        labels = np.full(image.shape[:2], BELT, dtype=np.int8)
        item = val >= self.item_min_value
        grey = item & (sat < self.grey_max_saturation)
        hued = item & ~grey
        bands = (
            ("red", (hue < self.red_max_hue) | (hue >= self.blue_max_hue)),
            ("brown", (hue >= self.red_max_hue) & (hue < self.brown_max_hue)),
            ("green", (hue >= self.brown_max_hue) & (hue < self.green_max_hue)),
            ("blue", (hue >= self.green_max_hue) & (hue < self.blue_max_hue)),
        )
        for name, band in bands:
            labels[hued & band] = COLOURS.index(name)
        count, blobs = cv2.connectedComponents(grey.astype(np.uint8), connectivity=8)
        if count > 1:
            size = np.bincount(blobs.ravel(), minlength=count)
            core = np.bincount(
                blobs.ravel(), weights=(val >= self.white_min_value).ravel(), minlength=count
            )
            white = core >= self.white_min_core * np.maximum(size, 1)
            names = np.where(white, COLOURS.index("white"), COLOURS.index("transparent"))
            labels[grey] = names[blobs[grey]]
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
    """

    code: int
    fraction: float
    colour: str | None
    pixels: np.ndarray


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
