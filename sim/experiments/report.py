"""A report of any run or sweep folder: means and 95 % intervals per grid point, paired
comparisons of the planners, figures, HTML.

`sortsim report DIR [DIR ...] [--out FOLDER] [--baseline NAME]` reads each folder's
`episodes.csv` (and its `manifest.json`, for the settings the CSV does not hold) and groups the
episodes by grid point: every setting in which they differ (`sim.experiments.reporting.groups`:
the code, catalogue, variant, perception, robots, coordination, cup, energy price, robots'
economics, belt speed, items, feed and planner), naming those grouping columns; a group whose
episodes differ in any other setting is refused in one line before anything is written. Per
group and metric it gives the mean and the half-width of its 95 % confidence interval
(Student's t over the seeds: t(0.975, n - 1) x sd / sqrt(n); none for a single episode; an
interval from fewer than 3 seeds is marked and explained). Metrics: profit, accuracy (SP/SI),
items picked, picks per minute (picked over the simulated minutes), wrong bins, missed, failed
picks and, where the CSV has it, the motors' electrical energy per pick: two tables, the means
and the sorting quality, so that each fits a page; then the recovery beside the purity per
material, the figures per hour, and, for grid points that differ in their robots only, what
each added robot earns and its payback (`sim.experiments.reporting.plant`).

Paired comparisons: every planner of a sweep runs on the same seeds' flows, so at each grid
point each planner is compared with a baseline (`--baseline NAME`, else the grid point's best
planner by mean profit) over the seeds both ran: the mean of the per-seed differences (profit,
accuracy) with its 95 % interval from the paired Student's t (`scipy.stats.ttest_rel`'s test,
its p-value beside) and a verdict: better or worse when the interval excludes 0, else no
difference at 95 %.

Planners are shown by short labels: a built-in one by its name, a user's `module:Class` or
`path/file.py:Class` by its class's `name` attribute, else its class name (`planner_label`).
Figures (PNG, titled in words): profit, items picked, accuracy and picks per minute against
items (one line per planner and belt speed; against the belt speed when every episode has the
same item count); a run's timeline (its `timeline.csv`): picks per minute and profit over time,
the faults shaded (`sim.experiments.reporting.timeline_figure`). A thesis table's sweep (its
manifest names the table) also gets the thesis's
side-by-side layout. Written to FOLDER (default: `DIR/report`): `report.md`, the PNGs and
`report.html`, one self-contained page (the figures embedded).
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
import statistics
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from planner.decision.registry import is_user_spec, user_class
from sim.errors import InvalidInput
from sim.experiments.reporting import plant
from sim.experiments.reporting.groups import (
    GridColumns,
    Point,
    attach_configs,
    check_groups,
    constant_text,
    differing_elsewhere,
    grouping_text,
    point_of,
)
from sim.experiments.reporting.stats import (
    Estimate,
    estimate,
    few_seeds_note,
    paired_difference,
    seeds_cell,
)
from sim.experiments.reporting.stats import number as _number
from sim.experiments.reporting.timeline_figure import timeline_figures
from sim.results import detection_table, outputs

__all__ = ["Estimate", "estimate", "paired_difference"]
METRICS = (
    ("profit_eur", "profit [EUR]", "{:.2f}"),
    ("accuracy", "accuracy SP/SI", "{:.3f}"),
    ("picked", "picked", "{:.1f}"),
    ("picks_per_min", "picks per minute", "{:.1f}"),
    ("wrong_bin", "wrong bin", "{:.1f}"),
    ("missed", "missed", "{:.1f}"),
    ("failed_picks", "failed picks", "{:.1f}"),
    ("energy_per_pick_j", "energy per pick [J]", "{:.0f}"),
)
MAIN_METRICS = ("profit_eur", "accuracy", "picked", "picks_per_min", "energy_per_pick_j")
"""The means table's metrics; the others (wrong bins, misses, failed picks) make the sorting
quality's table (the purity stands beside the recovery per material: `reporting.plant`)."""
FIGURES = (
    ("profit_eur", "profit [EUR]", "Profit"),
    ("picked", "items picked", "Items picked"),
    ("accuracy", "accuracy SP/SI", "Accuracy (picked over entered)"),
    ("picks_per_min", "picks per minute", "Picks per minute"),
)
"""(metric, axis label, title in words) of each figure."""
PAIRED_METRICS = (
    ("profit_eur", "Profit [EUR]", "{:.2f}"),
    ("accuracy", "Accuracy SP/SI", "{:.3f}"),
)
"""(metric, heading, format) of the paired comparisons; higher is better for each."""
MEANS_METHOD = "Student's t over the seeds"
PAIRED_METHOD = "paired t-test, scipy.stats.ttest_rel"


def derived(row: dict) -> dict[str, float]:
    """The metrics of one episodes.csv row that are present (picks per minute and energy per
    pick derived from their columns)."""
    out = {}
    for key in [key for key, _, _ in METRICS]:
        value = _number(row.get(key))
        if value is not None:
            out[key] = value
    picked, sim_s = _number(row.get("picked")), _number(row.get("sim_s"))
    if picked is not None and sim_s:
        out["picks_per_min"] = picked / (sim_s / 60.0)
    energy = _number(row.get("energy_elec_j"))
    if energy is not None and picked:
        out["energy_per_pick_j"] = energy / picked
    return out


def read_folders(folders: list[Path]) -> tuple[list[dict], list[str]]:
    """(every episode row of the folders, the thesis table ids their sweeps name).

    Each row carries its episode's recorded config (`reporting.groups.attach_configs`).

    Raises:
        InvalidInput: A folder without episodes, a row without its grid columns, or a group of
            episodes that differ in a setting the report cannot group by (`check_groups`).
    """
    rows, tables = [], []
    for folder in folders:
        folder = Path(folder)
        path = folder / "episodes.csv"
        if not path.is_file():
            raise InvalidInput("DIR", "a run or sweep folder holding episodes.csv", str(folder))
        read = outputs.read_rows(path)
        for line, row in enumerate(read, start=2):
            _check_row(row, path, line)
        attach_configs(read, folder)
        rows += read
        table = _table_of(folder)
        if table:
            tables.append(table)
    if not rows:
        raise InvalidInput("DIR", "folders whose episodes.csv holds episodes", folders)
    check_groups(rows)
    return rows, tables


def _check_row(row: dict, path: Path, line: int) -> None:
    """Refuse a row without the grid columns a report groups by, or with non-numbers in them."""
    for column, kind in (("planner", str), ("speed_factor", float), ("n_items", int)):
        text = row.get(column)
        try:
            ok = text not in (None, "") and (kind is str or math.isfinite(cast(float, kind(text))))
        except ValueError:
            ok = False
        if not ok:
            allowed = f"an episodes.csv whose rows have {column} ({kind.__name__})"
            raise InvalidInput(column, allowed, text, f"{path} line {line}")


def _table_of(folder: Path) -> str | None:
    """The thesis table a sweep folder reproduces, from its manifest or its sweep config."""
    manifest = folder / "manifest.json"
    if manifest.is_file():
        try:
            config = json.loads(manifest.read_text(encoding="utf-8")).get("config", {})
            if isinstance(config, dict) and config.get("table"):
                return str(config["table"])
        except (OSError, ValueError):
            pass
    return None


def group_key(row: dict) -> Point:
    """The grid point of a row: every grouping setting's value (`reporting.groups.point_of`)."""
    return point_of(row)


def summarise(rows: list[dict]) -> dict[Point, dict[str, Estimate]]:
    """{grid point: {metric: Estimate}} over the rows (sorted by grid point)."""
    values: dict[Point, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for row in rows:
        metrics = values[group_key(row)]  # a group even when none of its metrics is present
        for key, value in derived(row).items():
            metrics[key].append(value)
    return {
        group: {k: estimate(v) for k, v in metrics.items()}
        for group, metrics in sorted(values.items())
    }


def planner_label(spec: str) -> str:
    """The short name a report shows for a planner of episodes.csv.

    A built-in planner is its name. A user's `module:Class` or `path/file.py:Class` is its
    class's `name` attribute when it has one (a class attribute, else one its constructor
    sets: user planners are built with no arguments, as an episode builds them), else the class
    name; a spec that no longer imports (a file moved, another working directory) is the text
    after its last colon.
    """
    if not is_user_spec(spec):
        return spec
    try:
        cls = user_class(spec)
    except Exception:  # a report never fails over a label
        return spec.rpartition(":")[2] or spec
    name = getattr(cls, "name", None)
    if not isinstance(name, str):
        try:
            name = getattr(cls(), "name", None)
        except Exception:
            name = None
    return name.strip() if isinstance(name, str) and name.strip() and name != spec else cls.__name__


def planner_labels(specs) -> dict[str, str]:
    """{spec: short label} of the planners of a report, every label unique (two specs of the
    same short name keep their whole specs)."""
    specs = list(dict.fromkeys(specs))
    labels = {s: planner_label(s) for s in specs}
    counts: defaultdict[str, int] = defaultdict(int)
    for label in labels.values():
        counts[label] += 1
    return {s: (label if counts[label] == 1 else s) for s, label in labels.items()}


def metrics_present(summary: dict[Point, dict[str, Estimate]]) -> list[tuple[str, str, str]]:
    """(column, label, format) of the metrics of `METRICS` some group has."""
    return [m for m in METRICS if any(m[0] in s for s in summary.values())]


def _md_table(head: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(cells) + " |" for cells in rows]
    return "\n".join(lines)


def markdown(
    summary: dict[Point, dict[str, Estimate]],
    labels: dict[str, str] | None = None,
    which: str = "all",
) -> str:
    """The means ± 95 % half-widths as a markdown table.

    `which`: "all" (every metric present, one wide table), "main" (profit, accuracy, picks,
    energy: `MAIN_METRICS`) or "quality" (wrong bins, misses, failed picks). The grid point's
    settings that are the same on every row are left out but the belt and items
    (`GridColumns`); planners are shown by their short labels (`planner_labels`); a seed count
    under 3 is marked and explained under the table.
    """
    labels = labels or {}
    present = metrics_present(summary)
    if which == "main":
        present = [m for m in present if m[0] in MAIN_METRICS]
    elif which == "quality":
        present = [m for m in present if m[0] not in MAIN_METRICS]
    if not present:
        return ""
    grid = GridColumns.of(summary)
    head = grid.head() + ["planner", "n"] + [m[1] for m in present]
    rows, counts = [], []
    for group, metrics in summary.items():
        n = max((e.n for e in metrics.values()), default=0)
        cells = grid.cells(group) + [labels.get(group["planner"], group["planner"])]
        cells += [seeds_cell(n)]
        cells += [metrics[k].text(fmt) if k in metrics else "" for k, _, fmt in present]
        rows.append(cells)
        counts.append(n)
    note = few_seeds_note(counts)
    return _md_table(head, rows) + (f"\n\n{note}" if note else "")


@dataclass(frozen=True)
class Paired:
    """One planner against the baseline at one grid point, over the seeds both ran.

    Attributes:
        point: The grid point, its planner "" (`Point.replace(planner="")`).
        planner: The planner's spec (as episodes.csv has it).
        baseline: The baseline's spec.
        metric: The metric compared (`PAIRED_METRICS`).
        planner_mean: The planner's mean over the paired seeds (its own 95 % interval).
        baseline_mean: The baseline's, over the same seeds.
        difference: Mean of the per-seed differences, planner minus baseline.
        low: Lower end of the difference's 95 % interval (nan: fewer than 2 seeds).
        high: Upper end.
        p: Two-sided p-value of the paired t-test (nan: fewer than 2 seeds).
    """

    point: Point
    planner: str
    baseline: str
    metric: str
    planner_mean: Estimate
    baseline_mean: Estimate
    difference: float
    low: float
    high: float
    p: float

    @property
    def n(self) -> int:
        """Seeds both ran."""
        return self.planner_mean.n

    @property
    def verdict(self) -> str:
        """'better' or 'worse' when the 95 % interval of the difference excludes 0 (higher is
        better for every metric compared), else 'no difference at 95 %'."""
        if self.n < 2:
            return "too few seeds"
        if self.low > 0.0:
            return "better"
        if self.high < 0.0:
            return "worse"
        return "no difference at 95 %"


def _by_seed(rows: list[dict]) -> dict[Point, dict[str, dict[int, dict[str, float]]]]:
    """{grid point without planner: {planner: {seed: metrics}}}; a seed a planner ran twice at a
    grid point (the same run read from two folders) counts once, its first row."""
    out: dict[Point, dict[str, dict[int, dict[str, float]]]] = defaultdict(
        lambda: defaultdict(dict)
    )
    for row in rows:
        key = group_key(row)
        seed = _number(row.get("seed"))
        if seed is None:
            continue
        out[key.replace(planner="")][key["planner"]].setdefault(int(seed), derived(row))
    return out


def best_planner(runs: dict[str, dict[int, dict[str, float]]], metric: str = "profit_eur"):
    """The planner of highest mean `metric` over its seeds (ties: the first by name), or None."""
    means = {}
    for planner, seeds in runs.items():
        values = [m[metric] for m in seeds.values() if metric in m]
        if values:
            means[planner] = statistics.fmean(values)
    if not means:
        return None
    return max(sorted(means), key=lambda p: means[p])


def _baseline_at(runs: dict, baseline: str | None, labels: dict[str, str]) -> str | None:
    if baseline is None:
        return best_planner(runs)
    for spec in sorted(runs):
        if baseline in (spec, labels.get(spec)):
            return spec
    return None


def paired_comparisons(
    rows: list[dict], baseline: str | None = None, labels: dict[str, str] | None = None
) -> tuple[list[Paired], list[str]]:
    """Every other planner against the baseline at each grid point, per metric of
    `PAIRED_METRICS`, over the seeds both ran (the same seeds' flows).

    Args:
        rows: episodes.csv rows.
        baseline: A planner's spec or short label; None: each grid point's best planner by mean
            profit.
        labels: {spec: short label} (`planner_labels`).

    Returns:
        (the comparisons, notes on grid points left out: the baseline did not run there, or a
        planner shares no seed with it).
    """
    labels = labels or {}
    out, notes = [], []
    by_seed = _by_seed(rows)
    grid = GridColumns.of(by_seed)
    for point, runs in sorted(by_seed.items()):
        where = grid.where(point)
        base = _baseline_at(runs, baseline, labels)
        if base is None:
            notes.append(f"{where}: {baseline} did not run there.")
            continue
        for planner in sorted(runs, key=lambda p: labels.get(p, p)):
            if planner == base:
                continue
            seeds = sorted(set(runs[planner]) & set(runs[base]))
            if not seeds:
                notes.append(
                    f"{where}: {labels.get(planner, planner)} shares no seed with "
                    f"{labels.get(base, base)}."
                )
                continue
            for metric, *_ in PAIRED_METRICS:
                pairs = [(runs[planner][s].get(metric), runs[base][s].get(metric)) for s in seeds]
                paired = [(a, b) for a, b in pairs if a is not None and b is not None]
                if not paired:
                    continue
                a, b = [x for x, _ in paired], [y for _, y in paired]
                diff, low, high, p = paired_difference(a, b)
                out.append(
                    Paired(
                        point, planner, base, metric, estimate(a), estimate(b), diff, low, high, p
                    )  # fmt: skip
                )
    return out, notes


def _signed(value: float, fmt: str) -> str:
    text = fmt.format(value)
    return text if text.startswith(("-", "+")) else "+" + text


def paired_markdown(comparisons: list[Paired], labels: dict[str, str] | None = None) -> str:
    """The paired comparisons as one markdown table per metric (a '### label' heading each)."""
    labels = labels or {}
    grid = GridColumns.of(c.point for c in comparisons)
    note = few_seeds_note(c.n for c in comparisons)
    parts = []
    for metric, title, fmt in PAIRED_METRICS:
        chosen = [c for c in comparisons if c.metric == metric]
        if not chosen:
            continue
        head = grid.head() + ["planner", "baseline", "seeds", "planner's mean"]
        head += ["baseline's mean", "difference [95 % interval]", "p", "verdict"]
        rows = []
        for c in chosen:
            interval = (
                "" if math.isnan(c.low) else f" [{_signed(c.low, fmt)}, {_signed(c.high, fmt)}]"
            )
            p = "" if math.isnan(c.p) else (f"{c.p:.2f}" if c.p >= 0.01 else f"{c.p:.0e}")
            rows.append(
                grid.cells(c.point)
                + [labels.get(c.planner, c.planner), labels.get(c.baseline, c.baseline)]
                + [seeds_cell(c.n), c.planner_mean.text(fmt), c.baseline_mean.text(fmt)]
                + [_signed(c.difference, fmt) + interval, p, c.verdict]
            )
        parts.append(f"### {title}\n\n{_md_table(head, rows)}")
    return "\n\n".join(parts + ([note] if parts and note else []))


def paired_intro(baseline: str | None) -> str:
    """What the paired comparisons are, in words (the report's and the page's paragraph)."""
    against = f"`{baseline}`" if baseline else "the best planner of the grid point (by mean profit)"
    return (
        f"Each planner against {against}, over the seeds both ran: every planner of a sweep "
        "runs on the same seeds' flows, so the seeds pair the episodes. Difference = planner's "
        "mean minus the baseline's, with its 95 % interval from the paired Student's t over "
        f"the seeds ({PAIRED_METHOD}); p is the test's two-sided p-value. Verdict: better or "
        "worse when the interval excludes 0, else no difference at 95 %."
    )


def figures(
    summary: dict[Point, dict[str, Estimate]], labels: dict[str, str] | None = None
) -> dict[str, tuple[str, bytes]]:
    """{file name: (title in words, PNG bytes)}: each of `FIGURES` against items (or belt
    speed), one line per planner and every other grouping setting that differs (the belt
    speed or the items among them), error bars the 95 % intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = labels or {}
    against_items = len({g["items"] for g in summary}) > 1
    axis = "items" if against_items else "speed"
    series_of = GridColumns(tuple(n for n in GridColumns.of(summary).names if n != axis))
    out = {}
    for metric, label, words in FIGURES:
        lines: dict[tuple, list[tuple[float, Estimate]]] = defaultdict(list)
        for point, metrics in summary.items():
            if metric in metrics:
                name = labels.get(point["planner"], point["planner"])
                lines[(name, series_of.where(point))].append((point[axis], metrics[metric]))
        if not lines:
            continue
        title = f"{words} against {'items' if against_items else 'belt speed'}"
        fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
        for (name, where), points in sorted(lines.items()):
            points.sort(key=lambda p: p[0])
            xs = [p[0] for p in points]
            ys = [p[1].mean for p in points]
            err = [0.0 if math.isnan(p[1].half_width) else p[1].half_width for p in points]
            ax.errorbar(xs, ys, yerr=err, marker="o", capsize=3, label=f"{name} {where}")
        ax.set_title(title)
        ax.set_xlabel("items" if against_items else "belt speed factor")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        buffer = io.BytesIO()
        fig.savefig(buffer, format="png")
        plt.close(fig)
        out[f"{metric}.png"] = (title, buffer.getvalue())
    return out


@dataclass(frozen=True)
class Section:
    """A part of the report: a heading, a paragraph, then markdown (tables, '###' headings)."""

    heading: str
    text: str
    body: str


VERDICTS = ("better", "worse", "no difference at 95 %", "too few seeds")


def _cell_class(text: str) -> str:
    """A verdict's cell class (left-aligned, better and worse in bold)."""
    if text not in VERDICTS:
        return ""
    return ' class="verdict strong"' if text in VERDICTS[:2] else ' class="verdict"'


def _html_body(body: str) -> list[str]:
    """HTML of a section's markdown body: its tables, '### ' headings and paragraphs."""
    parts: list[str] = []
    table: list[str] = []

    def flush() -> None:
        if not table:
            return
        cells = [[c.strip() for c in r.strip().strip("|").split("|")] for r in table]
        cells = [c for c in cells if not all(set(x) <= {"-"} and x for x in c)]
        parts.append("<table>")
        parts.append("<tr>" + "".join(f"<th>{html.escape(c)}</th>" for c in cells[0]) + "</tr>")
        for row in cells[1:]:
            tds = (f"<td{_cell_class(c)}>{html.escape(c)}</td>" for c in row)
            parts.append("<tr>" + "".join(tds) + "</tr>")
        parts.append("</table>")
        table.clear()

    for line in body.splitlines():
        if line.startswith("|"):
            table.append(line)
            continue
        flush()
        if line.startswith("### "):
            parts.append(f"<h3>{html.escape(line[4:])}</h3>")
        elif line.strip():
            parts.append(f"<p>{html.escape(line.replace('`', ''))}</p>")
    flush()
    return parts


STYLE = (
    "body{font-family:sans-serif;margin:1.5em;max-width:1150px}"
    "table{border-collapse:collapse;font-size:0.8em;margin-bottom:1em}"
    "td,th{border:1px solid #bbb;padding:3px 6px;text-align:right}"
    "th{background:#eee;white-space:normal;vertical-align:bottom}td{white-space:nowrap}"
    "td.verdict{text-align:left;white-space:normal}td.strong{font-weight:bold}pre{background:#f6f6f6;padding:1em;overflow-x:auto}"
    "img{max-width:100%}"
)
"""The page's style: tables within a 1200 px window (headers wrap; the widest table, the
paired comparisons', is about 900 px at this font)."""


def page(
    title: str, sections: list[Section], thesis: list[str], images: dict[str, tuple[str, bytes]]
) -> str:
    """One self-contained HTML page: the sections' tables, the thesis tables, the figures
    embedded (each under its title in words)."""
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title>",
        f"<style>{STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
    ]
    for section in sections:
        parts.append(f"<h2>{html.escape(section.heading)}</h2>")
        if section.text:
            parts.append(f"<p>{html.escape(section.text.replace('`', ''))}</p>")
        parts += _html_body(section.body)
    for text in thesis:
        parts.append(f"<h2>The thesis's table, ours (thesis)</h2><pre>{html.escape(text)}</pre>")
    for words, png in images.values():
        data = base64.b64encode(png).decode("ascii")
        parts.append(f'<h2>{html.escape(words)}</h2><img alt="{html.escape(words)}" ')
        parts[-1] += f'src="data:image/png;base64,{data}">'
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def check_baseline(rows: list[dict], baseline: str | None) -> None:
    """Refuse a `--baseline` that names no planner of the rows (by spec or short label)."""
    if baseline is None:
        return
    specs = list(dict.fromkeys(r["planner"] for r in rows))
    labels = planner_labels(specs)
    if baseline not in specs and baseline not in labels.values():
        names = ", ".join(sorted(set(labels.values())))
        raise InvalidInput("--baseline", f"a planner of the episodes: {names}", baseline)


def _means_text(summary: dict[Point, dict[str, Estimate]], rows: list[dict], labels) -> str:
    """The means' paragraph: the grouping columns, the method, what every episode shares, the
    settings that differ between groups only, the planners' short labels."""
    renamed = [f"{label} = `{spec}`" for spec, label in labels.items() if label != spec]
    lines = [grouping_text(summary)]
    lines += [f"Means over seeds ± the half-width of the 95 % interval ({MEANS_METHOD})."]
    lines += [constant_text(summary)] if constant_text(summary) else []
    elsewhere = differing_elsewhere(rows)
    if elsewhere:
        lines += [f"Between groups (never within one) the episodes also differ in "
                  f"{', '.join(elsewhere)}."]  # fmt: skip
    lines += ["Planners: " + "; ".join(renamed) + "."] if renamed else []
    return " ".join(lines)


def _detection(rows: list[dict], labels: dict[str, str], grid: GridColumns) -> str:
    def group(row: dict) -> tuple[Point, list[str]]:
        point = group_key(row)
        return point, grid.cells(point) + [labels.get(point["planner"], point["planner"])]

    return detection_table.detection_markdown(rows, labels, group, grid.head() + ["planner"])


def sections(rows: list[dict], baseline: str | None = None) -> tuple[list[Section], dict]:
    """The report's sections (means, sorting quality, recovery and purity, per hour, the added
    robots, detection, paired comparisons) and the planners' labels."""
    summary = summarise(rows)
    labels = planner_labels(g["planner"] for g in summary)
    main = markdown(summary, labels, "main")
    out = [Section("Means per grid point", _means_text(summary, rows, labels), main)]
    quality = markdown(summary, labels, "quality")
    if quality:
        out.append(Section("Sorting quality", "Counts per episode, means.", quality))
    for heading, text, body in (
        (plant.RECOVERY_HEADING, plant.RECOVERY_TEXT, plant.recovery_markdown(rows, labels)),
        (plant.PER_HOUR_HEADING, plant.PER_HOUR_TEXT, plant.per_hour_markdown(rows, labels)),
        (plant.ROBOTS_HEADING, plant.ROBOTS_TEXT, plant.robots_markdown(rows, labels)),
        (
            detection_table.HEADING,
            detection_table.TEXT,
            _detection(rows, labels, GridColumns.of(summary)),
        ),
    ):
        if body:
            out.append(Section(heading, text, body))
    comparisons, notes = paired_comparisons(rows, baseline, labels)
    if comparisons or notes:
        body = paired_markdown(comparisons, labels)
        body += ("\n\n" + "\n".join(notes)) if notes else ""
        out.append(Section("Paired comparisons", paired_intro(baseline), body))
    return out, labels


def write_report(folders: list[Path], out: Path, baseline: str | None = None) -> list[Path]:
    """Write the report of `folders` into `out`; the files written.

    Args:
        folders: Run or sweep folders (each with episodes.csv).
        out: The report's folder.
        baseline: The planner every other is compared with (spec or short label); None: each
            grid point's best by mean profit.
    """
    from sim.experiments.thesis import thesis_report

    rows, tables = read_folders(folders)
    check_baseline(rows, baseline)
    parts, labels = sections(rows, baseline)
    thesis = []
    for table_id in dict.fromkeys(tables):
        text = thesis_report.format_table(table_id, rows)
        if text:
            thesis.append(text)
    images = figures(summarise(rows), labels) | timeline_figures(folders)
    title = "sortsim report: " + ", ".join(Path(f).name for f in folders)
    md = [f"# {title}", ""]
    for section in parts:
        md += [f"## {section.heading}", "", section.text, "", section.body, ""]
    for text in thesis:
        md += ["```", text, "```", ""]
    for name, (words, _) in images.items():
        md += [f"### {words}", "", f"![{words}]({name})", ""]
    written = [outputs.write_atomic(out / "report.md", "\n".join(md))]
    for name, (_, png) in images.items():
        written.append(outputs.write_atomic(out / name, png))
    written.append(outputs.write_atomic(out / "report.html", page(title, parts, thesis, images)))
    return written
