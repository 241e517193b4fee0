"""`sortsim/PickOrder-v0`'s picture: the belt from above, drawn with OpenCV on a NumPy array.

The belt runs left to right (+x), y up; drawn: the belt (its width), where items come into
view (`view_start_x`, dashed), the robot's reachable window (green outline), the three bins
beside the belt (each labelled with its material and the items in it), every item still on the
belt as a dot in its true material's colour (faded before it comes into view), the candidates
of the current decision ringed and numbered by their slot, the cup's position (red cross), and
a line of counters (time, belt speed, picked, profit).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from sim.render.labels import CLASS_COLOURS, CLASS_SHORT

SIZE = (800, 520)
"""The picture's (width, height) [px]."""
X_RANGE_M = (-1.7, 1.0)
"""The belt's stretch drawn, along x [m] (the view starts at -1.5 m, the window ends near 0.6)."""
BELT_HALF_WIDTH_M = 0.4
"""Half the thesis's belt width [m] (a scene's `belt_half_width` by default)."""
ITEM_RADIUS_M = 0.035
"""The dot of an item [m]."""
BIN_HALF_M = (0.09, 0.12)
"""Half the size of a bin's drawn opening along x and y [m]."""


@dataclass
class BeltScene:
    """What the picture shows.

    Attributes:
        items: (x, y, true class id) of the items still on the belt [m].
        candidates: (x, y) of the current decision's candidates, slot 0 first [m].
        tcp: The cup's (x, y) [m].
        window: Reachable window: (y samples, x entry, x exit) [m].
        bins: Release point (x, y) of each material's bin by class id [m].
        binned: Items in each bin by class id.
        view_start_x: Where items come into view [m].
        counters: The line of text at the top.
        belt_half_width: Half the belt's width [m].
    """

    items: list[tuple[float, float, int]]
    candidates: list[tuple[float, float]]
    tcp: tuple[float, float]
    window: tuple[np.ndarray, np.ndarray, np.ndarray]
    bins: dict[int, tuple[float, float]]
    binned: dict[int, int]
    view_start_x: float
    counters: str
    belt_half_width: float = BELT_HALF_WIDTH_M


def _px(x: float, y: float, size=SIZE) -> tuple[int, int]:
    width, height = size
    scale = width / (X_RANGE_M[1] - X_RANGE_M[0])
    u = (x - X_RANGE_M[0]) * scale
    v = height / 2.0 - y * scale
    return int(round(u)), int(round(v))


def _scale(size=SIZE) -> float:
    return size[0] / (X_RANGE_M[1] - X_RANGE_M[0])


def _text(img, text, org, scale=0.45, colour=(255, 255, 255), thickness=1) -> int:
    """Draw `text` at `org` (its bottom left) [px]; returns its width [px]."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    cv2.putText(img, text, org, font, scale, colour, thickness, cv2.LINE_AA)
    return cv2.getTextSize(text, font, scale, thickness)[0][0]


def _belt(img: np.ndarray, scene: BeltScene) -> None:
    top_left = _px(X_RANGE_M[0], scene.belt_half_width)
    bottom_right = _px(X_RANGE_M[1], -scene.belt_half_width)
    cv2.rectangle(img, top_left, bottom_right, (78, 78, 84), -1)
    u = _px(scene.view_start_x, 0.0)[0]
    top, bottom = top_left[1], bottom_right[1]
    for v in range(top, bottom, 12):
        cv2.line(img, (u, v), (u, min(v + 6, bottom)), (200, 200, 200), 1)
    _text(img, "in view", (u + 4, bottom - 6), 0.4, (200, 200, 200))
    y, x_in, x_out = scene.window
    ok = np.isfinite(x_in) & np.isfinite(x_out)
    if ok.any():
        ys = y[ok]
        edge = [_px(x, yy) for x, yy in zip(x_in[ok], ys, strict=True)]
        edge += [_px(x, yy) for x, yy in zip(x_out[ok][::-1], ys[::-1], strict=True)]
        cv2.polylines(img, [np.array(edge, np.int32)], True, (90, 210, 110), 2, cv2.LINE_AA)
        u, v = max(edge)  # the window's downstream end
        _text(img, "reach", (u - 40, v - 8), 0.4, (90, 210, 110))


def _bins(img: np.ndarray, scene: BeltScene) -> None:
    hx, hy = BIN_HALF_M
    for cls, (x, y) in scene.bins.items():
        colour = CLASS_COLOURS.get(cls, (200, 200, 200))
        a, b = _px(x - hx, y + hy), _px(x + hx, y - hy)
        cv2.rectangle(img, a, b, (40, 40, 40), -1)
        cv2.rectangle(img, a, b, colour, 2)
        label = f"{CLASS_SHORT.get(cls, '?')} {scene.binned.get(cls, 0)}"
        (w, _), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, 0.5, 1)
        u = (a[0] + b[0] - w) // 2
        v = b[1] + 18 if y < 0 else a[1] - 8
        _text(img, label, (u, v), 0.5, colour)


def draw(scene: BeltScene, size=SIZE) -> np.ndarray:
    """The picture of a scene.

    Args:
        size: (width, height) [px]; the scale follows the width.

    Returns:
        The RGB picture (height, width, 3) uint8.
    """
    if tuple(size) != SIZE:
        return cv2.resize(draw(scene), tuple(size), interpolation=cv2.INTER_AREA)
    img = np.full((SIZE[1], SIZE[0], 3), 28, dtype=np.uint8)
    _belt(img, scene)
    _bins(img, scene)
    radius = max(2, int(round(ITEM_RADIUS_M * _scale())))
    for x, y, cls in scene.items:
        colour = np.array(CLASS_COLOURS.get(cls, (200, 200, 200)), dtype=float)
        if x < scene.view_start_x:
            colour = 0.35 * colour + 0.65 * np.array((78, 78, 84))
        cv2.circle(img, _px(x, y), radius, tuple(int(c) for c in colour), -1, cv2.LINE_AA)
    for slot, (x, y) in enumerate(scene.candidates):
        p = _px(x, y)
        cv2.circle(img, p, radius + 4, (255, 255, 255), 2, cv2.LINE_AA)
        _text(img, str(slot), (p[0] + radius + 4, p[1] - radius - 2), 0.5)
    u, v = _px(*scene.tcp)
    cv2.line(img, (u - 9, v - 9), (u + 9, v + 9), (255, 60, 60), 3, cv2.LINE_AA)
    cv2.line(img, (u - 9, v + 9), (u + 9, v - 9), (255, 60, 60), 3, cv2.LINE_AA)
    _text(img, scene.counters, (8, 20), 0.55)
    u, v, grey = 8, SIZE[1] - 10, (200, 200, 200)
    u += _text(img, "items by true material:", (u, v), 0.42, grey) + 6
    for cls in sorted(CLASS_SHORT):
        u += _text(img, CLASS_SHORT[cls], (u, v), 0.42, CLASS_COLOURS[cls]) + 6
    _text(img, " rings: the candidates, by slot   x: the cup", (u, v), 0.42, grey)
    return img
