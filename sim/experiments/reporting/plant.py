"""The report's tables in a plant's terms: recovery beside purity per material, the figures per
hour, and what each added robot earns and how soon it pays back.

- **Recovery and purity per material**: per grid point and material, the items that entered,
  the recovery (items of the material in its own bin / items of it that entered: the target a
  plant sets) and the purity of its bin (its own material's share of what the bin holds),
  means over the seeds with their 95 % intervals.
- **Per hour** (episodes.csv's columns, `sim.results.economics`): items and kilograms into
  their own bin per hour, the profit per hour net of energy, the robots' cost per hour and
  the profit per hour after it.
- **Robots**: grid points that differ in the robot count only (a line's coordination aside:
  a single robot heads every coordination's series) form a series; each line of the series is
  set against the one before it: the profit per hour each added robot brings, the mean of the
  per-seed differences over the seeds both ran with its paired 95 % interval, and the added
  robot's payback in years, capital / (extra profit per hour x hours per year - maintenance per
  year), from the mean and from the interval's ends ('never': the extra profit does not cover
  the maintenance).
"""

from __future__ import annotations

import json
import math
from collections import defaultdict

from sim.experiments.reporting.groups import GridColumns, Point, point_of
from sim.experiments.reporting.stats import (
    estimate,
    few_seeds_note,
    number,
    paired_difference,
    seeds_cell,
)
from sim.results.economics import payback_years

RECOVERY_HEADING = "Recovery and purity per material"
RECOVERY_TEXT = (
    "Per material: the items that entered (mean per episode), the recovery (items of the "
    "material in its own bin / items of it that entered) and the purity of its bin (its own "
    "material's share of what the bin holds), means over the seeds ± the half-width of the 95 "
    "% interval. A bin left empty has no purity; a material none of which entered, no recovery."
)
PER_HOUR_HEADING = "Per hour"
PER_HOUR_TEXT = (
    "Over the hours of feed (an episode's totals over its duration_s: a line that runs all day "
    "sorts, each such stretch, what one feed brings): items and kilograms into their own bin, "
    "the profit net of the motors' energy, the robots' cost ([economics]: capital over its "
    "life's hours plus maintenance) and the profit after it; means ± 95 % half-widths."
)
ROBOTS_HEADING = "What each added robot earns"
ROBOTS_TEXT = (
    "Grid points that differ only in their robots, each against the line before it: the "
    "profit per hour (net of energy) that each added robot brings, the mean of the per-seed "
    "differences over the seeds both ran with its 95 % interval (paired Student's t), and the "
    "added robot's payback: capital / (extra profit per hour x hours per year - maintenance "
    "per year), from the mean [and from the interval's ends]; never: the extra profit does not "
    "cover the maintenance."
)


def _groups(rows: list[dict]) -> dict[Point, list[dict]]:
    out: dict[Point, list[dict]] = defaultdict(list)
    for row in rows:
        out[point_of(row)].append(row)
    return dict(sorted(out.items()))


def _values(members: list[dict], column: str) -> list[float]:
    return [v for v in (number(r.get(column)) for r in members) if v is not None]


def _text(values: list[float], fmt: str) -> str:
    return estimate(values).text(fmt) if values else "-"


def _with_note(table: str, counts) -> str:
    note = few_seeds_note(counts)
    return f"{table}\n\n{note}" if note else table


def _table(head: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return "\n".join(lines + ["| " + " | ".join(cells) + " |" for cells in rows])


def materials_of(rows: list[dict]) -> list[str]:
    """The materials of the rows' `recovery_<material>` and `purity_<material>` columns, in the
    order the CSVs give them."""
    out: list[str] = []
    for row in rows:
        for key in row:
            if key.startswith(("recovery_", "purity_")):
                name = key.partition("_")[2]
                if name not in out:
                    out.append(name)
    return out


def recovery_markdown(rows: list[dict], labels: dict[str, str] | None = None) -> str:
    """The recovery and purity per material, one table row per grid point and material ("" when
    the CSVs have neither)."""
    labels = labels or {}
    materials = materials_of(rows)
    if not materials:
        return ""
    groups = _groups(rows)
    grid = GridColumns.of(groups)
    head = grid.head() + ["planner", "material", "seeds", "entered", "recovery", "purity"]
    table, counts = [], []
    for point, members in groups.items():
        for name in materials:
            recovery = _values(members, f"recovery_{name}")
            purity = _values(members, f"purity_{name}")
            if not recovery and not purity:
                continue
            entered = _values(members, f"entered_{name}")
            cells = grid.cells(point) + [labels.get(point["planner"], point["planner"]), name]
            cells += [seeds_cell(len(members))]
            cells += [f"{sum(entered) / len(entered):.1f}" if entered else "-"]
            cells += [_text(recovery, "{:.3f}"), _text(purity, "{:.3f}")]
            table.append(cells)
            counts.append(len(members))
    return _with_note(_table(head, table), counts) if table else ""


PER_HOUR = (
    ("recovered_items_per_h", "items/h", "{:.0f}"),
    ("recovered_kg_per_h", "kg/h", "{:.2f}"),
    ("profit_per_h_eur", "profit/h [EUR]", "{:.2f}"),
    ("robot_cost_per_h_eur", "robots' cost/h [EUR]", "{:.2f}"),
)
"""(column, heading, format) of the per-hour table; then the profit after the robots."""


def per_hour_markdown(rows: list[dict], labels: dict[str, str] | None = None) -> str:
    """The figures per hour per grid point ("" when the CSVs have no `profit_per_h_eur`)."""
    labels = labels or {}
    if not any(number(r.get("profit_per_h_eur")) is not None for r in rows):
        return ""
    groups = _groups(rows)
    grid = GridColumns.of(groups)
    head = grid.head() + ["planner", "seeds"] + [h for _, h, _ in PER_HOUR]
    head.append("profit/h after robots [EUR]")
    table = []
    for point, members in groups.items():
        cells = grid.cells(point) + [labels.get(point["planner"], point["planner"])]
        cells += [seeds_cell(len(members))]
        cells += [_text(_values(members, c), fmt) for c, _, fmt in PER_HOUR]
        after = [
            p - c
            for p, c in (
                (number(r.get("profit_per_h_eur")), number(r.get("robot_cost_per_h_eur")))
                for r in members
            )
            if p is not None and c is not None
        ]
        table.append(cells + [_text(after, "{:.2f}")])
    return _with_note(_table(head, table), [len(m) for m in groups.values()])


LINE_VARIANT_KEYS = ("variant.robots", "variant.coordination")
"""A sweep's variant columns of the line itself: variants that differ in these only are one
series of the robots' table."""


def _series_key(point: Point, members: list[dict]) -> Point:
    """The point with its robots taken out: its robot count, and, in a sweep, its variant's
    name for the settings the variant changes besides the line (`LINE_VARIANT_KEYS`)."""
    settings = {
        k: v
        for k, v in members[0].items()
        if k.startswith("variant.") and k not in LINE_VARIANT_KEYS
    }
    line = "variant.robots" in members[0]
    variant = json.dumps(sorted(settings.items())) if line else point["variant"]
    return point.replace(robots=0, variant=variant)


def robot_series(groups: dict[Point, list[dict]]) -> list[list[Point]]:
    """The series of grid points that differ in their robots only (in a sweep, variants that
    change the line only: `LINE_VARIANT_KEYS`), each sorted by its robot count; a single robot
    heads the series of every coordination. Only series of two or more."""
    lines: dict[Point, dict[int, Point]] = defaultdict(dict)
    singles: dict[Point, Point] = {}
    for point, members in groups.items():
        key = _series_key(point, members)
        if point["robots"] == 1:
            singles[key.replace(coordination="")] = point
        else:
            lines[key][point["robots"]] = point
    out = []
    for key, series in sorted(lines.items()):
        single = singles.get(key.replace(coordination=""))
        if single is not None:
            series[1] = single
        if len(series) > 1:
            out.append([series[n] for n in sorted(series)])
    return out


def _per_seed(members: list[dict]) -> dict[int, float]:
    out: dict[int, float] = {}
    for row in members:
        seed, value = number(row.get("seed")), number(row.get("profit_per_h_eur"))
        if seed is not None and value is not None:
            out.setdefault(int(seed), value)
    return out


def _years(value: float) -> str:
    return "never" if math.isinf(value) else f"{value:.1f}"


def payback_text(economics: tuple, extra: float, low: float, high: float) -> str:
    """The payback of one added robot from the mean extra profit per hour (and from its
    interval's ends when known), or '-' without the robots' economics."""
    if not economics:
        return "-"
    capital, _, hours, maintenance = economics
    text = _years(payback_years(capital, extra, hours, maintenance))
    if math.isnan(low):
        return text
    slow = _years(payback_years(capital, low, hours, maintenance))
    fast = _years(payback_years(capital, high, hours, maintenance))
    return f"{text} [{fast}, {slow}]"


def _step_cells(before: list[dict], after: list[dict], added: int, economics: tuple) -> list[str]:
    """(seeds, extra profit per hour per added robot [interval], payback) of one step."""
    a, b = _per_seed(after), _per_seed(before)
    seeds = sorted(set(a) & set(b))
    if not seeds:
        return ["0", "no shared seed", "-"]
    diff, low, high, _ = paired_difference([a[s] for s in seeds], [b[s] for s in seeds])
    diff, low, high = diff / added, low / added, high / added
    extra = f"{diff:+.2f}" + ("" if math.isnan(low) else f" [{low:+.2f}, {high:+.2f}]")
    return [seeds_cell(len(seeds)), extra, payback_text(economics, diff, low, high)]


def robots_markdown(rows: list[dict], labels: dict[str, str] | None = None) -> str:
    """The robots' table: every series of grid points that differ in their robots only ("" when
    there is none, or the CSVs have no `profit_per_h_eur`)."""
    labels = labels or {}
    if not any(number(r.get("profit_per_h_eur")) is not None for r in rows):
        return ""
    groups = _groups(rows)
    series = robot_series(groups)
    if not series:
        return ""
    grid = GridColumns.of(groups)
    head = grid.head() + ["planner", "seeds", "profit/h [EUR]"]
    head += ["extra profit/h per added robot [EUR]", "payback per added robot [years]"]
    table, counts = [], []
    for points in series:
        for k, point in enumerate(points):
            members = groups[point]
            profit = _text(_values(members, "profit_per_h_eur"), "{:.2f}")
            cells = grid.cells(point) + [labels.get(point["planner"], point["planner"])]
            if k == 0:
                step = [seeds_cell(len(members)), "-", "-"]
            else:
                added = point["robots"] - points[k - 1]["robots"]
                step = _step_cells(groups[points[k - 1]], members, added, point["economics"])
            table.append(cells + [step[0], profit, *step[1:]])
            counts.append(len(members))
    return _with_note(_table(head, table), counts)
