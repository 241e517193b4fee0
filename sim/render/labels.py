"""The video's annotations: class labels and colours, label placement, the counters' panel.

`Overlay` is what a frame shows besides the scene: each tracked item's predicted class next to
where the cell believes it is, the chosen next pick(s) boxed, and lines of counters (picks,
misses, profit, each bin's purity so far, `purity_text`). `annotate` draws it over an RGB frame
with OpenCV; labels never overlap one another or the panel (`place_label`): a crowded item
keeps its dot only. The live viewer shows the same `Overlay` its own way.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

LABEL_OFFSETS = ((4, -4), (4, 12), (-34, -4), (-34, 12), (4, -18), (-34, -18), (4, 26))
"""Where a label is tried around its item's dot [px], in turn, until it overlaps no other."""
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
    """

    items: list[tuple[int, float, float, float, int, float]] = field(default_factory=list)
    next_pick: int | None = None
    next_picks: tuple[int, ...] = ()
    counters: list[str] = field(default_factory=list)
    short: dict[int, str] = field(default_factory=lambda: dict(CLASS_SHORT))
    colours: dict[int, tuple[int, int, int]] = field(default_factory=lambda: dict(CLASS_COLOURS))


def _overlaps(box, boxes) -> bool:
    x0, y0, x1, y1 = box
    return any(x0 < b[2] and b[0] < x1 and y0 < b[3] and b[1] < y1 for b in boxes)


def place_label(p, size, taken: list) -> tuple[int, int] | None:
    """Where a label goes near its item's dot.

    Args:
        p: The dot's pixel (u, v) [px].
        size: The label's (width, height) [px].
        taken: Boxes (x0, y0, x1, y1) [px] already taken; the label's box joins them.

    Returns:
        The label's bottom-left corner [px] at the first of `LABEL_OFFSETS` where it overlaps
        no box in `taken`, or None: no room.
    """
    w, h = size
    for dx, dy in LABEL_OFFSETS:
        x, y = p[0] + dx, p[1] + dy
        box = (x - 1, y - h - 1, x + w + 1, y + 2)
        if not _overlaps(box, taken):
            taken.append(box)
            return x, y
    return None


def annotate(frame: np.ndarray, uv: np.ndarray, overlay: Overlay) -> np.ndarray:
    """Draw the overlay on an RGB frame, in place.

    Every item gets its dot; labels are placed so that none overlaps another or the counters'
    panel (`place_label`), the next picks' first: where items crowd, some dots go unlabelled
    rather than have their labels pile up.

    Args:
        frame: The RGB frame (height, width, 3) uint8.
        uv: Each overlay item's pixel (N, 2) [px] (NaN: not in view).
        overlay: What to draw.

    Returns:
        `frame`.
    """
    font = cv2.FONT_HERSHEY_SIMPLEX
    taken = []
    if overlay.counters:
        h = 8 + 16 * len(overlay.counters)
        w = 12 + max(cv2.getTextSize(t, font, 0.42, 1)[0][0] for t in overlay.counters)
        taken.append((0, 0, w, h))
    picks = {overlay.next_pick, *overlay.next_picks} - {None}
    order = sorted(zip(overlay.items, uv, strict=True), key=lambda e: e[0][0] not in picks)
    for (track_id, *_, cls, prob), (u, v) in order:
        if not (np.isfinite(u) and np.isfinite(v)):
            continue
        p = (int(round(u)), int(round(v)))
        colour = overlay.colours.get(cls, (200, 200, 200))
        cv2.circle(frame, p, 3, colour, -1, cv2.LINE_AA)
        name = overlay.short.get(cls, "?")
        label = f"{name} {prob:.0%}" if prob < 0.995 else name
        (w, h), _ = cv2.getTextSize(label, font, 0.33, 1)
        corner = place_label(p, (w, h), taken)
        if corner is not None:
            cv2.putText(frame, label, corner, font, 0.33, colour, 1, cv2.LINE_AA)
        if track_id in picks:
            cv2.rectangle(frame, (p[0] - 10, p[1] - 10), (p[0] + 10, p[1] + 10), (255, 60, 60), 2)
            cv2.putText(
                frame, "next", (p[0] - 12, p[1] + 22), font, 0.35, (255, 60, 60), 1, cv2.LINE_AA
            )
    if overlay.counters:
        h = 8 + 16 * len(overlay.counters)
        w = 12 + max(cv2.getTextSize(t, font, 0.42, 1)[0][0] for t in overlay.counters)
        patch = frame[0:h, 0:w]
        patch[:] = (0.35 * patch).astype(frame.dtype)  # darkened panel behind the text
    y = 16
    for line in overlay.counters:
        cv2.putText(frame, line, (6, y), font, 0.42, (255, 255, 255), 1, cv2.LINE_AA)
        y += 16
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
