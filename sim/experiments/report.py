"""A report of any run or sweep folder: means and 95 % intervals per grid point, figures, HTML.

`sortsim report DIR [DIR ...] [--out FOLDER]` reads each folder's `episodes.csv` and groups the
episodes by grid point: (variant, perception, belt speed factor, items, planner). Per group and
metric it gives the mean and the half-width of its 95 % confidence interval (Student's t over
the seeds: t(0.975, n - 1) x sd / sqrt(n); none for a single episode). Metrics: profit, accuracy
(SP/SI), items picked, picks per minute (picked over the simulated minutes), wrong bins, missed,
failed picks, and, where the CSV has them, the motors' electrical energy per pick and the bins'
purity. Figures (PNG): profit, accuracy and picks per minute against items (one line per planner
and belt speed; against the belt speed when every episode has the same item count). A thesis
table's sweep (its manifest or sweep.json names the table) also gets the thesis's side-by-side
layout. Written to FOLDER (default: `DIR/report`): `report.md`, the PNGs and `report.html`, one
self-contained page (the figures embedded).
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

from sim.errors import InvalidInput
from sim.results import outputs

GROUP_KEYS = ("variant", "perception", "speed_factor", "n_items", "planner")
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
PURITY_PREFIX = "purity_"
"""Each material's bin purity (`purity_<material>`: the catalogue's materials) is a metric too."""
FIGURES = (
    ("profit_eur", "profit [EUR]"),
    ("picked", "items picked"),
    ("accuracy", "accuracy SP/SI"),
    ("picks_per_min", "picks per minute"),
)


@dataclass(frozen=True)
class Estimate:
    """Mean of a metric over a group's episodes and its 95 % interval's half-width (nan: n 1)."""

    mean: float
    half_width: float
    n: int

    def text(self, fmt: str) -> str:
        if math.isnan(self.half_width):
            return fmt.format(self.mean)
        return f"{fmt.format(self.mean)} ± {fmt.format(self.half_width)}"


def estimate(values: list[float]) -> Estimate:
    """Mean and 95 % Student-t half-width of `values` (at least one)."""
    from scipy import stats

    n = len(values)
    mean = statistics.fmean(values)
    if n < 2:
        return Estimate(mean, math.nan, n)
    half = float(stats.t.ppf(0.975, n - 1)) * statistics.stdev(values) / math.sqrt(n)
    return Estimate(mean, half, n)


def _number(text: str | None) -> float | None:
    if text is None or text == "":
        return None
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def derived(row: dict) -> dict[str, float]:
    """The metrics of one episodes.csv row that are present (picks per minute and energy per
    pick derived from their columns)."""
    out = {}
    keys = [key for key, _, _ in METRICS] + [k for k in row if k.startswith(PURITY_PREFIX)]
    for key in keys:
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
    """(every episode row of the folders, the thesis table ids their sweeps name)."""
    rows, tables = [], []
    for folder in folders:
        folder = Path(folder)
        path = folder / "episodes.csv"
        if not path.is_file():
            raise InvalidInput("DIR", "a run or sweep folder holding episodes.csv", str(folder))
        for number, row in enumerate(outputs.read_rows(path), start=2):
            _check_row(row, path, number)
            rows.append(row)
        table = _table_of(folder)
        if table:
            tables.append(table)
    if not rows:
        raise InvalidInput("DIR", "folders whose episodes.csv holds episodes", folders)
    return rows, tables


def _check_row(row: dict, path: Path, line: int) -> None:
    """Refuse a row without the grid columns a report groups by, or with non-numbers in them."""
    for column, kind in (("planner", str), ("speed_factor", float), ("n_items", int)):
        text = row.get(column)
        try:
            ok = text not in (None, "") and (kind is str or math.isfinite(kind(text)))
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


def group_key(row: dict) -> tuple:
    return (
        row.get("variant") or "base",
        row.get("perception") or "",
        float(row["speed_factor"]),
        int(row["n_items"]),
        row["planner"],
    )


def summarise(rows: list[dict]) -> dict[tuple, dict[str, Estimate]]:
    """{grid point: {metric: Estimate}} over the rows (sorted by grid point)."""
    values: dict[tuple, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for row in rows:
        for key, value in derived(row).items():
            values[group_key(row)][key].append(value)
    return {
        group: {k: estimate(v) for k, v in metrics.items()}
        for group, metrics in sorted(values.items())
    }


def metrics_present(summary: dict[tuple, dict[str, Estimate]]) -> list[tuple[str, str, str]]:
    """(column, label, format) of the metrics some group has: `METRICS`, then every material's
    purity in the order the episodes.csv columns gave them."""
    present = [m for m in METRICS if any(m[0] in s for s in summary.values())]
    purities: list[str] = []
    for metrics in summary.values():
        purities += [k for k in metrics if k.startswith(PURITY_PREFIX) and k not in purities]
    labels = [(k, "purity " + k.removeprefix(PURITY_PREFIX), "{:.3f}") for k in purities]
    return present + labels


def markdown(summary: dict[tuple, dict[str, Estimate]]) -> str:
    """The means ± 95 % half-widths as a markdown table (columns: the metrics present)."""
    present = metrics_present(summary)
    head = ["variant", "perception", "belt", "items", "planner", "n"] + [m[1] for m in present]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for (variant, perception, speed, items, planner), metrics in summary.items():
        n = max(e.n for e in metrics.values())
        cells = [variant, perception, f"x{speed:g}", str(items), planner, str(n)]
        cells += [metrics[k].text(fmt) if k in metrics else "" for k, _, fmt in present]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def figures(summary: dict[tuple, dict[str, Estimate]]) -> dict[str, bytes]:
    """{file name: PNG bytes}: each of `FIGURES` against items (or belt speed), one line per
    planner and belt speed (or items), error bars the 95 % intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    items = {g[3] for g in summary}
    against_items = len(items) > 1
    several_perceptions = len({g[1] for g in summary}) > 1
    out = {}
    for metric, label in FIGURES:
        lines: dict[tuple, list[tuple[float, Estimate]]] = defaultdict(list)
        for (variant, perception, speed, n_items, planner), metrics in summary.items():
            if metric not in metrics:
                continue
            series = (variant, perception, planner, speed if against_items else n_items)
            x = n_items if against_items else speed
            lines[series].append((x, metrics[metric]))
        if not lines:
            continue
        fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
        for (variant, perception, planner, other), points in sorted(lines.items()):
            points.sort(key=lambda p: p[0])
            xs = [p[0] for p in points]
            ys = [p[1].mean for p in points]
            err = [0.0 if math.isnan(p[1].half_width) else p[1].half_width for p in points]
            tag = f"x{other:g}" if against_items else f"{other} items"
            name = planner if variant == "base" else f"{variant}/{planner}"
            name += f" ({perception})" if several_perceptions else ""
            ax.errorbar(xs, ys, yerr=err, marker="o", capsize=3, label=f"{name} {tag}")
        ax.set_xlabel("items" if against_items else "belt speed factor")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        buffer = io.BytesIO()
        fig.savefig(buffer, format="png")
        plt.close(fig)
        out[f"{metric}.png"] = buffer.getvalue()
    return out


def page(title: str, table_md: str, thesis: list[str], images: dict[str, bytes]) -> str:
    """One self-contained HTML page: the table, the thesis tables, the figures embedded."""
    rows = [r for r in table_md.splitlines() if not r.startswith("|---")]
    cells = [[c.strip() for c in r.strip("|").split("|")] for r in rows]
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title>",
        "<style>body{font-family:sans-serif;margin:2em}"
        "table{border-collapse:collapse;font-size:0.8em}.wide{overflow-x:auto}"
        "td,th{border:1px solid #bbb;padding:3px 6px;text-align:right}td{white-space:nowrap}"
        "th{background:#eee}pre{background:#f6f6f6;padding:1em}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        "<p>Means over seeds ± the half-width of the 95 % confidence interval (Student's t).</p>",
        '<div class="wide"><table>',
        "<tr>" + "".join(f"<th>{html.escape(c)}</th>" for c in cells[0]) + "</tr>",
    ]
    for row in cells[1:]:
        parts.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>")
    parts.append("</table></div>")
    for text in thesis:
        parts.append(f"<h2>The thesis's table, ours (thesis)</h2><pre>{html.escape(text)}</pre>")
    for name, png in images.items():
        data = base64.b64encode(png).decode("ascii")
        parts.append(f'<h2>{html.escape(name)}</h2><img alt="{html.escape(name)}" ')
        parts[-1] += f'src="data:image/png;base64,{data}">'
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def write_report(folders: list[Path], out: Path) -> list[Path]:
    """Write the report of `folders` into `out`; the files written."""
    from sim.experiments import thesis_report

    rows, tables = read_folders(folders)
    summary = summarise(rows)
    table_md = markdown(summary)
    thesis = []
    for table_id in dict.fromkeys(tables):
        text = thesis_report.format_table(table_id, rows)
        if text:
            thesis.append(text)
    images = figures(summary)
    title = "sortsim report: " + ", ".join(Path(f).name for f in folders)
    md = [f"# {title}", "", "Means ± 95 % interval half-width (Student's t over seeds).", ""]
    md += [table_md, ""]
    for text in thesis:
        md += ["```", text, "```", ""]
    md += [f"![{name}]({name})" for name in images]
    written = [outputs.write_atomic(out / "report.md", "\n".join(md) + "\n")]
    for name, png in images.items():
        written.append(outputs.write_atomic(out / name, png))
    written.append(outputs.write_atomic(out / "report.html", page(title, table_md, thesis, images)))
    return written
