"""The report's detection against density: how many items the camera never found as belts fill.

Camera-perception episodes only (truth perception detects every item by construction). One row
per grid point (variant, planner, belt speed, items; a report passes its own grouping, every
setting in which its episodes differ), ordered by the belt's density
(`items_per_m` of episodes.csv: items over the metres of belt passing during the flow's
arrival): items that entered, never detected and never visible (under 30 % of the top area ever
seen: buried under other items) as shares of them, pooled over the seeds, and items picked.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Hashable
from typing import cast

HEADING = "Detection against density"
TEXT = (
    "Camera perception's items never detected and never visible (under 30 % of the top area "
    "ever seen by a camera: buried) as shares of the items that entered, pooled over the "
    "seeds, against the belt's items per metre."
)
GRID_COLUMNS = ("variant", "planner", "belt", "items")
"""The grid point's columns by default (a report passes its own: `Grouping`)."""
COLUMNS = (
    *GRID_COLUMNS,
    "items per metre",
    "n",
    "entered",
    "never detected",
    "never visible",
    "picked",
)


def _number(text) -> float | None:
    if text is None or text == "":
        return None
    try:
        return float(text)
    except ValueError:
        return None


def _share(part: float, whole: float) -> str:
    return f"{100 * part / whole:.1f} %" if whole > 0 else "-"


Grouping = Callable[[dict], tuple[Hashable, list[str]]]
"""A row's group: (its key, its grid point's cells in the table)."""


def _default_group(labels: dict[str, str]) -> Grouping:
    def group(row: dict) -> tuple[tuple, list[str]]:
        variant, planner = row.get("variant", ""), row.get("planner", "")
        factor, items = row.get("speed_factor", ""), row.get("n_items", "")
        belt = f"x{float(factor):g}" if _number(factor) is not None else str(factor)
        return (variant, planner, factor, items), [
            variant, labels.get(planner, planner), belt, str(items)
        ]  # fmt: skip

    return group


def detection_rows(
    rows: list[dict], labels: dict[str, str] | None = None, group: Grouping | None = None
) -> list[list[str]]:
    """The table's cells: one row per camera grid point, densest last.

    Args:
        rows: episodes.csv rows.
        labels: {planner spec: short label}.
        group: A row's group key and grid cells; by default (variant, planner, belt, items).
    """
    group = group or _default_group(labels or {})
    groups: dict[Hashable, list[dict]] = defaultdict(list)
    grid: dict[Hashable, list[str]] = {}
    for row in rows:
        if row.get("perception") != "camera":
            continue
        key, cells = group(row)
        groups[key].append(row)
        grid[key] = cells
    table = []
    for key, members in groups.items():
        entered = sum(_number(r.get("entered")) or 0.0 for r in members)
        never = sum(_number(r.get("never_detected")) or 0.0 for r in members)
        visible = [_number(r.get("never_visible")) for r in members]
        picked = sum(_number(r.get("picked")) or 0.0 for r in members) / len(members)
        densities = [d for d in (_number(r.get("items_per_m")) for r in members) if d is not None]
        density = sum(densities) / len(densities) if densities else None
        buried = _share(sum(cast(list[float], visible)), entered) if None not in visible else "-"
        cells = [
            *grid[key],
            "-" if density is None else f"{density:.1f}",
            str(len(members)),
            f"{entered / len(members):.1f}",
            _share(never, entered),
            buried,
            f"{picked:.1f}",
        ]
        table.append((density if density is not None else float("inf"), cells))
    table.sort(key=lambda entry: entry[0])
    return [cells for _, cells in table]


def detection_markdown(
    rows: list[dict],
    labels: dict[str, str] | None = None,
    group: Grouping | None = None,
    head: list[str] | None = None,
) -> str:
    """The section's markdown table, or "" when no episode used the camera.

    Args:
        rows: episodes.csv rows.
        labels: {planner spec: short label}.
        group: A row's group key and grid cells (`detection_rows`).
        head: The grid cells' headings (`GRID_COLUMNS` by default).
    """
    cells = detection_rows(rows, labels, group)
    if not cells:
        return ""
    columns = [*(head or GRID_COLUMNS), *COLUMNS[len(GRID_COLUMNS) :]]
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(c) + " |" for c in cells]
    return "\n".join(lines)
