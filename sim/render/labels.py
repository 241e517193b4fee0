"""The video's annotations: class labels and colours, label placement, the counters' panel.

`Overlay` is what a frame shows besides the scene: each tracked item's predicted class next to
where the cell believes it is, the chosen next pick(s) boxed, each bin labelled with its
material and the items in it (and how many of them belong elsewhere, `BinLabel`), and lines of
counters (picks, misses, wrong bins, profit, each bin's purity so far, `purity_text`).
`annotate` draws it over an RGB frame with OpenCV, its text and marks sized to the frame
(`TEXT_SCALE` at `REFERENCE_HEIGHT`, in proportion above and below); labels never overlap one
another, the bins' or the panel (`place_label`): a crowded item keeps its dot only. The live
viewer shows the same `Overlay` its own way.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

LABEL_OFFSETS = ((4, -4), (4, 12), (-34, -4), (-34, 12), (4, -18), (-34, -18), (4, 26))
"""Where a label is tried around its item's dot [px at a text scale of 1], in turn, until it
overlaps no other."""
REFERENCE_HEIGHT = 360
"""The frame height [px] the text sizes below are given for; a frame of another height scales
them in proportion (a 720 px frame's text is twice as large in pixels, the same on screen)."""
TEXT_SCALE = 1.35
"""Text and marks at `REFERENCE_HEIGHT` relative to the sizes of before (item labels OpenCV
font scale 0.33, counters 0.42 at 16 px a line): larger, to be read on a 640 x 360 video."""
ITEM_FONT = 0.33
"""OpenCV font scale of an item's label at a text scale of 1."""
PANEL_FONT = 0.42
"""OpenCV font scale of the counters at a text scale of 1 (`PANEL_LINE` px a line)."""
PANEL_LINE = 16
BIN_FONT = 0.42
"""OpenCV font scale of a bin's label at a text scale of 1."""
WRONG_COLOUR = (255, 80, 80)
"""RGB of the wrong-bin counts."""
CLASS_COLOURS = {2: (230, 170, 60), 3: (80, 200, 255), 4: (235, 235, 235)}
"""RGB (frames are RGB, not OpenCV's BGR) of each thesis class id (paper, plastic, aluminium)."""
CLASS_SHORT = {2: "PAP", 3: "PL", 4: "AL"}
"""Short label of each thesis class id."""
PALETTE = (
    (230, 170, 60), (80, 200, 255), (235, 235, 235), (120, 230, 120),
    (255, 120, 200), (255, 230, 90), (170, 140, 255), (255, 140, 90),
)  # fmt: skip
"""Label colours of a catalogue's materials, in material order (the first three the thesis's)."""
_THESIS_SHORT = {"paper": "PAP", "plastic": "PL", "aluminium": "AL"}


def class_labels(materials) -> tuple[dict[int, str], dict[int, tuple[int, int, int]]]:
    """The overlays' short labels and colours of a catalogue's classes.

    Args:
        materials: The catalogue's materials (`ids`, `names`).

    Returns:
        ({class id: short label}, {class id: RGB}): the thesis's PAP, PL, AL, else the name's
        first four letters in capitals (PET, HDPE); colours from `PALETTE` in material order.
    """
    pairs = zip(materials.ids, materials.names, strict=True)
    short = {c: _THESIS_SHORT.get(n, n[:4].upper()) for c, n in pairs}
    colours = {c: PALETTE[k % len(PALETTE)] for k, c in enumerate(materials.ids)}
    return short, colours


@dataclass(frozen=True)
class BinLabel:
    """A bin's label: its material and what landed in it.

    Attributes:
        cls: The bin's material class id.
        x: x of the point the label marks (the bin's rim centre) [m].
        y: Its y [m].
        z: Its z [m].
        count: Items in the bin.
        wrong: Those of them of another material.
    """

    cls: int
    x: float
    y: float
    z: float
    count: int = 0
    wrong: int = 0


@dataclass
class Overlay:
    """What the frame's annotations show.

    Attributes:
        items: (track id, x, y, z, predicted class id, probability) of each tracked item [m].
        next_pick: Track id of the chosen next pick, or None.
        next_picks: Track ids of every robot's pick under way (a line's robots), with
            `next_pick` among them.
        counters: Lines of text for the top-left corner.
        short: Short label of each class id (the materials').
        colours: RGB of each class id's labels.
        bins: Each bin's label (`BinLabel`), drawn at its rim.
        wrong_line: Index of the counter line to draw in `WRONG_COLOUR` (the wrong-bin count
            once it is above 0), or None.
    """

    items: list[tuple[int, float, float, float, int, float]] = field(default_factory=list)
    next_pick: int | None = None
    next_picks: tuple[int, ...] = ()
    counters: list[str] = field(default_factory=list)
    short: dict[int, str] = field(default_factory=lambda: dict(CLASS_SHORT))
    colours: dict[int, tuple[int, int, int]] = field(default_factory=lambda: dict(CLASS_COLOURS))
    bins: list[BinLabel] = field(default_factory=list)
    wrong_line: int | None = None


def _overlaps(box, boxes) -> bool:
    x0, y0, x1, y1 = box
    return any(x0 < b[2] and b[0] < x1 and y0 < b[3] and b[1] < y1 for b in boxes)


def place_label(p, size, taken: list, scale: float = 1.0) -> tuple[int, int] | None:
    """Where a label goes near its item's dot.

    Args:
        p: The dot's pixel (u, v) [px].
        size: The label's (width, height) [px].
        taken: Boxes (x0, y0, x1, y1) [px] already taken; the label's box joins them.
        scale: The frame's text scale: `LABEL_OFFSETS` are multiplied by it.

    Returns:
        The label's bottom-left corner [px] at the first of `LABEL_OFFSETS` where it overlaps
        no box in `taken`, or None: no room.
    """
    w, h = size
    for dx, dy in LABEL_OFFSETS:
        x, y = p[0] + int(round(dx * scale)), p[1] + int(round(dy * scale))
        box = (x - 1, y - h - 1, x + w + 1, y + 2)
        if not _overlaps(box, taken):
            taken.append(box)
            return x, y
    return None


def text_scale(frame: np.ndarray) -> float:
    """The text scale of a frame: `TEXT_SCALE` at `REFERENCE_HEIGHT`, in proportion to its
    height."""
    return TEXT_SCALE * frame.shape[0] / REFERENCE_HEIGHT


def _panel_size(counters: list[str], scale: float) -> tuple[int, int]:
    """(width, height) [px] of the counters' panel."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    line, thick = int(round(PANEL_LINE * scale)), _thickness(scale)
    widths = (cv2.getTextSize(t, font, PANEL_FONT * scale, thick)[0][0] for t in counters)
    return int(12 * scale) + max(widths), int(8 * scale) + line * len(counters)


def _thickness(scale: float) -> int:
    """Stroke width of text [px] at a text scale."""
    return max(1, int(round(scale * 0.8)))


def _bin_box(width: int, height: int, u: float, v: float, frame_width: int, taken: list):
    """Where a bin's label box (x0, y0, x1, y1) goes: centred over its rim point, else moved
    right, then left, past the labels already placed (bins side by side), else up."""
    x0, y1 = int(round(u)) - width // 2, int(round(v))
    box = (x0, y1 - height, x0 + width, y1)
    for _ in range(len(taken) + 1):
        hit = [b for b in taken if _overlaps(box, [b])]
        if not hit:
            return box
        right = max(b[2] for b in hit) + 4
        left = min(b[0] for b in hit) - 4 - width
        if right + width <= frame_width and not _overlaps(
            (right, box[1], right + width, y1), taken
        ):
            return (right, box[1], right + width, box[3])
        if left >= 0 and not _overlaps((left, box[1], left + width, box[3]), taken):
            return (left, box[1], left + width, box[3])
        top = min(b[1] for b in hit) - 4
        box = (box[0], top - height, box[2], top)
    return box


def _draw_bins(frame: np.ndarray, bin_uv, overlay: Overlay, scale: float, taken: list) -> None:
    """Each bin's label in a dark box edged in its material's colour over its rim: 'PAP 12',
    and ' 1 wrong' in `WRONG_COLOUR` when some item in it is of another material. Labels of
    bins side by side are moved apart (`_bin_box`), a line leading to their bin."""
    font, size = cv2.FONT_HERSHEY_SIMPLEX, BIN_FONT * scale
    thick = _thickness(scale)
    pad = int(round(4 * scale))
    placed: list = []
    shown = [
        (lab, uv) for lab, uv in zip(overlay.bins, bin_uv, strict=True) if np.isfinite(uv).all()
    ]
    for label, (u, v) in sorted(shown, key=lambda e: e[1][0]):
        colour = overlay.colours.get(label.cls, (200, 200, 200))
        main = f"{overlay.short.get(label.cls, '?')} {label.count}"
        extra = f" {label.wrong} wrong" if label.wrong else ""
        (w1, h), _ = cv2.getTextSize(main, font, size, thick)
        w2 = cv2.getTextSize(extra, font, size, thick)[0][0] if extra else 0
        width, height = w1 + w2 + 2 * pad, h + 2 * pad
        box = _bin_box(width, height, u, v - pad, frame.shape[1], placed)
        placed.append(box)
        anchor = (int(round(u)), int(round(v)))
        if not (box[0] <= anchor[0] <= box[2] and box[3] >= anchor[1] - 2 * pad):
            foot = (min(max(anchor[0], box[0]), box[2]), box[3])
            cv2.line(frame, foot, anchor, colour, thick, cv2.LINE_AA)
        x0, y0, x1, y1 = (max(c, 0) for c in box)
        patch = frame[y0:y1, x0:x1]
        patch[:] = (0.3 * patch).astype(frame.dtype)
        cv2.rectangle(frame, box[:2], box[2:], colour, thick, cv2.LINE_AA)
        org = (box[0] + pad, box[3] - pad)
        cv2.putText(frame, main, org, font, size, colour, thick, cv2.LINE_AA)
        if extra:
            org = (box[0] + pad + w1, box[3] - pad)
            cv2.putText(frame, extra, org, font, size, WRONG_COLOUR, thick, cv2.LINE_AA)
    taken.extend(placed)


def _draw_panel(frame: np.ndarray, overlay: Overlay, scale: float) -> None:
    """The counters' lines over a darkened panel in the top left corner."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    w, h = _panel_size(overlay.counters, scale)
    patch = frame[0:h, 0:w]
    patch[:] = (0.35 * patch).astype(frame.dtype)  # darkened panel behind the text
    line, thick = int(round(PANEL_LINE * scale)), _thickness(scale)
    y = line
    for k, text in enumerate(overlay.counters):
        colour = WRONG_COLOUR if k == overlay.wrong_line else (255, 255, 255)
        org = (int(6 * scale), y)
        cv2.putText(frame, text, org, font, PANEL_FONT * scale, colour, thick, cv2.LINE_AA)
        y += line


def annotate(
    frame: np.ndarray, uv: np.ndarray, overlay: Overlay, bin_uv: np.ndarray | None = None
) -> np.ndarray:
    """Draw the overlay on an RGB frame, in place.

    Every item gets its dot; labels are placed so that none overlaps another, a bin's label or
    the counters' panel (`place_label`), the next picks' first: where items crowd, some dots go
    unlabelled rather than have their labels pile up. Text and marks are sized to the frame
    (`text_scale`).

    Args:
        frame: The RGB frame (height, width, 3) uint8.
        uv: Each overlay item's pixel (N, 2) [px] (NaN: not in view).
        overlay: What to draw.
        bin_uv: Each of `overlay.bins`' pixel (M, 2) [px] (NaN: not in view); None: no bin
            labels.

    Returns:
        `frame`.
    """
    font = cv2.FONT_HERSHEY_SIMPLEX
    scale = text_scale(frame)
    taken = []
    if overlay.counters:
        taken.append((0, 0, *_panel_size(overlay.counters, scale)))
    if bin_uv is not None and overlay.bins:
        _draw_bins(frame, bin_uv, overlay, scale, taken)
    picks = {overlay.next_pick, *overlay.next_picks} - {None}
    order = sorted(zip(overlay.items, uv, strict=True), key=lambda e: e[0][0] not in picks)
    dot, box, size = max(2, int(round(3 * scale))), int(round(10 * scale)), ITEM_FONT * scale
    thick = _thickness(scale)
    for (track_id, *_, cls, prob), (u, v) in order:
        if not (np.isfinite(u) and np.isfinite(v)):
            continue
        p = (int(round(u)), int(round(v)))
        colour = overlay.colours.get(cls, (200, 200, 200))
        cv2.circle(frame, p, dot, colour, -1, cv2.LINE_AA)
        name = overlay.short.get(cls, "?")
        label = f"{name} {prob:.0%}" if prob < 0.995 else name
        (w, h), _ = cv2.getTextSize(label, font, size, thick)
        corner = place_label(p, (w, h), taken, scale)
        if corner is not None:
            cv2.putText(frame, label, corner, font, size, colour, thick, cv2.LINE_AA)
        if track_id in picks:
            red = (255, 60, 60)
            cv2.rectangle(frame, (p[0] - box, p[1] - box), (p[0] + box, p[1] + box), red, thick + 1)
            org = (p[0] - box, p[1] + box + int(round(12 * scale)))
            cv2.putText(frame, "next", org, font, 0.35 * scale, red, thick, cv2.LINE_AA)
    if overlay.counters:
        _draw_panel(frame, overlay, scale)
    return frame


def purity_text(binned: dict[int, tuple[int, int]], short: dict[int, str] = CLASS_SHORT) -> str:
    """Each bin's share of items of its own class so far, as one line.

    Args:
        binned: {item: (true class id, bin's class id)} of the items binned so far.
        short: Each bin's class id and label, in the order shown.

    Returns:
        'PAP 1.00  PL 0.95  AL -' ('-' for an empty bin).
    """
    parts = []
    for cls, label in short.items():
        in_bin = [t for t, b in binned.values() if b == cls]
        share = f"{sum(t == cls for t in in_bin) / len(in_bin):.2f}" if in_bin else "-"
        parts.append(f"{label} {share}")
    return "  ".join(parts)
