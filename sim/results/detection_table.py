"""The report's detection against density: how many items the camera never found as belts fill.

Camera-perception episodes only (truth perception detects every item by construction). One row
per grid point (variant, planner, belt speed, items), ordered by the belt's density
(`items_per_m` of episodes.csv: items over the metres of belt passing during the flow's
arrival): items that entered, never detected and never visible (under 30 % of the top area ever
seen: buried under other items) as shares of them, pooled over the seeds, and items picked.
"""

from __future__ import annotations

from collections import defaultdict

HEADING = "Detection against density"
TEXT = (
    "Camera perception's items never detected and never visible (under 30 % of the top area "
    "ever seen by a camera: buried) as shares of the items that entered, pooled over the "
    "seeds, against the belt's items per metre."
)
COLUMNS = (
    "variant",
    "planner",
    "belt",
    "items",
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


def detection_rows(rows: list[dict], labels: dict[str, str] | None = None) -> list[list[str]]:
    """The table's cells: one row per camera grid point, densest last."""
    labels = labels or {}
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for row in rows:
        if row.get("perception") != "camera":
            continue
        key = (row.get("variant", ""), row.get("planner", ""), row.get("speed_factor", ""))
        groups[(*key, row.get("n_items", ""))].append(row)
    table = []
    for (variant, planner, factor, items), group in groups.items():
        entered = sum(_number(r.get("entered")) or 0.0 for r in group)
        never = sum(_number(r.get("never_detected")) or 0.0 for r in group)
        visible = [_number(r.get("never_visible")) for r in group]
        picked = sum(_number(r.get("picked")) or 0.0 for r in group) / len(group)
        densities = [d for d in (_number(r.get("items_per_m")) for r in group) if d is not None]
        density = sum(densities) / len(densities) if densities else None
        buried = _share(sum(visible), entered) if None not in visible else "-"
        table.append(
            (
                density if density is not None else float("inf"),
                [
                    variant,
                    labels.get(planner, planner),
                    f"x{float(factor):g}" if _number(factor) is not None else str(factor),
                    str(items),
                    "-" if density is None else f"{density:.1f}",
                    str(len(group)),
                    f"{entered / len(group):.1f}",
                    _share(never, entered),
                    buried,
                    f"{picked:.1f}",
                ],
            )
        )
    table.sort(key=lambda entry: entry[0])
    return [cells for _, cells in table]


def detection_markdown(rows: list[dict], labels: dict[str, str] | None = None) -> str:
    """The section's markdown table, or "" when no episode used the camera."""
    cells = detection_rows(rows, labels)
    if not cells:
        return ""
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(c) + " |" for c in cells]
    return "\n".join(lines)
