"""Our sweep results beside the thesis's tables 4.2-4.6, and its figures 4.4-4.6.

Each table is printed in the thesis's layout with every cell as `ours (thesis)`; our value is
the mean over the seeds of the sweep's episodes.csv, one block or column per decision manager
(never mixed): `qlearning` is the thesis's algorithm as written (its "Our Method", whose
numbers stand in brackets), `rollout` ours (no thesis counterpart). The thesis's numbers are in
`sim/data/thesis_tables.toml`. `sortsim reproduce` (`sim.experiments.thesis.reproduce`) makes the
whole chapter as markdown.

Figures 4.4, 4.5 and 4.6 plot accuracy, time and profit against the dataset size, one line per
decision manager: ours solid with markers (mean over seeds, bars at min..max), the thesis's
dashed. A sweep's figures have one panel per belt speed (`save_figures`); `sortsim reproduce`
draws the same panels for both regimes (`sim.experiments.thesis.reproduce_figures`). A sweep folder
written before the rename holds the rollout under the name `qlearning` (`docs/results.md`).
"""

from __future__ import annotations

import tomllib
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from sim.paths import DATA_DIR  # noqa: E402

THESIS_TABLES = DATA_DIR / "thesis_tables.toml"


def thesis_tables() -> dict:
    """The thesis's numbers per table id ('4.2', ...)."""
    with THESIS_TABLES.open("rb") as f:
        return tomllib.load(f)["table"]


def _f(row: dict, key: str) -> float:
    return float(row.get(key) or 0.0)


def group_means(rows: list[dict], keys: tuple[str, ...]) -> dict[tuple, dict[str, float]]:
    """Mean of every numeric column per group of `keys` (speed factors rounded to 3 places)."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for row in rows:
        k = tuple(
            round(float(row[c]), 3) if c == "speed_factor" else row.get(c) or "base" for c in keys
        )
        groups[tuple(int(v) if c == "n_items" else v for c, v in zip(keys, k, strict=True))].append(
            row
        )
    out = {}
    for k, members in groups.items():
        cols: tuple[str, ...] = (
            "accuracy",
            "profit_eur",
            "sim_s",
            "picked",
            "picked_paper",
            "picked_plastic",
        )
        cols += ("picked_aluminium", "entered_paper", "entered_plastic", "entered_aluminium")
        means = {c: sum(_f(r, c) for r in members) / len(members) for c in cols}
        means["n"] = len(members)
        out[k] = means
    return out


def _cell(ours: float | None, theirs: float, fmt: str) -> str:
    left = "-" if ours is None else format(ours, fmt)
    return f"{left} ({format(theirs, fmt)})"


def planners_of(rows: list[dict]) -> list[str]:
    """The rows' decision managers, the thesis's (qlearning, proximity) first."""
    names = {r.get("planner") or "" for r in rows}
    return sorted(names, key=lambda p: (p not in ("qlearning", "proximity"), p))


def table_4_2(rows: list[dict], t: dict) -> str:
    means = group_means(rows, ("planner", "speed_factor", "n_items"))
    lines = [
        t["title"] + " - ours (thesis's Q-learning)",
        "items \\ speed " + "".join(f"{n:>18}" for n in t["items"]),
    ]
    for planner in planners_of(rows):
        lines.append(f"{planner}:")
        for i, f in enumerate(t["speed_factors"]):
            cells = [
                _cell(
                    means.get((planner, round(f, 3), n), {}).get("accuracy"),
                    t["accuracy"][i][j],
                    ".3f",
                )
                for j, n in enumerate(t["items"])
            ]
            lines.append(f"x{f:<13g}" + "".join(f"{c:>18}" for c in cells))
    return "\n".join(lines)


def table_4_3(rows: list[dict], t: dict) -> str:
    means = group_means(rows, ("planner", "variant"))
    head = f"{'':22}" + "".join(
        f"{h:>18}" for h in ("Class2 Picked", "Class3 Picked", "Class4 Picked")
    )
    lines = [t["title"] + " - ours (thesis)"]
    cols = ("picked_paper", "picked_plastic", "picked_aluminium")
    for planner in planners_of(rows):
        lines += [f"{planner}:", head]
        for variant, label, theirs in zip(t["variants"], t["labels"], t["picked"], strict=True):
            m = means.get((planner, variant), {})
            cells = [_cell(m.get(c), theirs[j], ".1f") for j, c in enumerate(cols)]
            lines.append(f"{label:22}" + "".join(f"{c:>18}" for c in cells))
        m = means.get((planner, "normal"), {})
        ent = ("entered_paper", "entered_plastic", "entered_aluminium")
        cells = [_cell(m.get(c), t["entered"][j], ".1f") for j, c in enumerate(ent)]
        lines.append(f"{'Sum of items per class':22}" + "".join(f"{c:>18}" for c in cells))
    return "\n".join(lines)


def table_4_4(rows: list[dict], t: dict) -> str:
    lines = [t["title"] + " - ours (thesis)"]
    for planner in planners_of(rows):
        mine = [r for r in rows if (r.get("planner") or "") == planner]
        lines += [f"{planner}:", f"{'':10}{'Accuracy':>18}{'Time(min)':>18}"]
        for i, row in enumerate(mine):
            theirs_a = t["accuracy"][i] if i < len(t["accuracy"]) else float("nan")
            theirs_t = t["time_min"][i] if i < len(t["time_min"]) else float("nan")
            a = _cell(_f(row, "accuracy"), theirs_a, ".4f")
            m = _cell(_f(row, "sim_s") / 60.0, theirs_t, ".2f")
            lines.append(f"seq. {i + 1:<5}{a:>18}{m:>18}")
        acc = sum(_f(r, "accuracy") for r in mine) / len(mine)
        mins = sum(_f(r, "sim_s") for r in mine) / len(mine) / 60.0
        a = _cell(acc, t["average_accuracy"], ".4f")
        m = _cell(mins, t["average_time_min"], ".2f")
        lines.append(f"{'Average':10}{a:>18}{m:>18}")
    return "\n".join(lines)


def table_4_5(rows: list[dict], t: dict) -> str:
    means = group_means(rows, ("planner", "n_items"))
    planners = planners_of(rows)
    short = {"proximity": "prox", "qlearning": "qlearning", "rollout": "rollout"}
    heads = [f"{m} {short.get(p, p)}" for m in ("Acc", "Time", "Profit") for p in planners]
    lines = [
        t["title"] + " - ours (thesis); qlearning: the thesis's algorithm as written (its "
        "Our Method), rollout: ours",
        f"{'items':>6}" + "".join(f"{h:>17}" for h in heads),
    ]
    for j, n in enumerate(t["items"]):
        cells = []
        for metric, key, fmt in (
            ("accuracy", "accuracy", ".3f"),
            ("time", "sim_s", ".1f"),
            ("profit", "profit_eur", ".2f"),
        ):
            for planner in planners:
                ours = means.get((planner, n), {}).get(key)
                theirs = t.get(f"{metric}_{planner}")
                cell = _cell(ours, theirs[j], fmt) if theirs else _plain(ours, fmt)
                cells.append(cell)
        lines.append(f"{n:>6}" + "".join(f"{c:>17}" for c in cells))
    return "\n".join(lines)


def _plain(ours: float | None, fmt: str) -> str:
    return "-" if ours is None else format(ours, fmt)


FORMATTERS = {
    "4.2": table_4_2,
    "4.3": table_4_3,
    "4.4": table_4_4,
    "4.5": table_4_5,
    "4.6": table_4_5,
}


def format_table(table_id: str | None, rows: list[dict]) -> str:
    """The thesis table `table_id` with our means beside its numbers ('' if unknown)."""
    if table_id not in FORMATTERS:
        return ""
    return "Table " + table_id + ": " + FORMATTERS[table_id](rows, thesis_tables()[table_id])


class DecisionFigure(NamedTuple):
    """One of the thesis's figures 4.4-4.6."""

    number: str
    metric: str
    """The thesis's name of it (`sim/data/thesis_tables.toml`: `<metric>_<planner>`)."""
    column: str
    """Our episodes.csv column."""
    ylabel: str


DECISION_FIGURES = (
    DecisionFigure("4.4", "accuracy", "accuracy", "accuracy (SP/SI)"),
    DecisionFigure("4.5", "time", "sim_s", "time [s]"),
    DecisionFigure("4.6", "profit", "profit_eur", "profit [EUR]"),
)
COLOURS = {"proximity": "tab:orange", "qlearning": "tab:blue", "rollout": "tab:green"}
LABELS = {
    "qlearning": "qlearning: the thesis's algorithm as written (here)",
    "rollout": "rollout: ours (here)",
    "proximity": "proximity (here)",
}
"""Legend of our lines by planner (another planner: its name and "(here)")."""
THESIS_LABELS = {"qlearning": "thesis: its Q-learning", "proximity": "thesis: proximity"}
"""Legend of the thesis's dashed lines."""

RowValue = Callable[[dict], float | None]
"""A row's number to plot (None: the row has none, e.g. no item of a class entered)."""


def column_value(name: str) -> RowValue:
    return lambda row: float(row[name])


def mean_and_range(groups: list[list[float]]) -> tuple[list[float], list[float], list[float]]:
    """Each group's mean and its distances down to the group's minimum and up to its maximum,
    as error bars (never negative: the mean of equal values may round past them)."""
    m = [sum(g) / len(g) for g in groups]
    lo = [max(0.0, a - min(g)) for a, g in zip(m, groups, strict=True)]
    hi = [max(0.0, max(g) - a) for a, g in zip(m, groups, strict=True)]
    return m, lo, hi


def series(rows: list[dict], planner: str, value: RowValue) -> tuple[list[int], list[list[float]]]:
    """The item counts of `planner`'s rows and, per count, the rows' values."""
    by_items: dict[int, list[float]] = defaultdict(list)
    for row in rows:
        if row["planner"] == planner:
            v = value(row)
            if v is not None:
                by_items[int(row["n_items"])].append(v)
    xs = sorted(by_items)
    return xs, [by_items[x] for x in xs]


def decision_panel(
    ax, rows: list[dict], planners, value: RowValue, thesis: dict | None, metric: str | None
) -> None:
    """One panel of figures 4.4-4.9: each planner's `value` against the dataset's size and,
    with `thesis` (its table at this belt speed) and `metric`, the thesis's dashed lines of the
    planners it has."""
    for planner in planners:
        xs, groups = series(rows, planner, value)
        if xs:
            m, lo, hi = mean_and_range(groups)
            ax.errorbar(
                xs,
                m,
                yerr=[lo, hi],
                marker="o",
                capsize=3,
                color=COLOURS.get(planner),
                label=LABELS.get(planner, f"{planner} (here)"),
            )
    if thesis is not None and metric is not None:
        for planner in (p for p in planners if p in THESIS_LABELS):
            ax.plot(
                thesis["items"],
                thesis[f"{metric}_{planner}"],
                "--",
                marker="x",
                color=COLOURS[planner],
                alpha=0.6,
                label=THESIS_LABELS[planner],
            )
    ax.set_xlabel("items in the dataset")
    ax.grid(alpha=0.3)


def _at_speed(rows: list[dict], factor: float) -> list[dict]:
    return [r for r in rows if abs(float(r["speed_factor"]) - factor) < 1e-6]


def _decision_figures(rows: list[dict], out_dir: Path, tables: dict) -> list[Path]:
    """Figures 4.4-4.6 of a sweep, one panel per belt speed."""
    factors = sorted({round(float(r["speed_factor"]), 3) for r in rows})
    thesis = {round(tables[k]["speed_factor"], 3): tables[k] for k in ("4.5", "4.6")}
    planners = planners_of(rows)
    paths = []
    for figure in DECISION_FIGURES:
        fig, axes = plt.subplots(1, len(factors), figsize=(5.5 * len(factors), 4), squeeze=False)
        for ax, factor, letter in zip(axes[0], factors, "abcdef", strict=False):
            value = column_value(figure.column)
            at = _at_speed(rows, factor)
            decision_panel(ax, at, planners, value, thesis.get(factor), figure.metric)
            ax.set_title(f"({letter}) speed x{factor:g}")
            ax.set_ylabel(figure.ylabel)
            ax.legend(fontsize=8)
        fig.suptitle(
            f"Figure {figure.number}: {figure.metric} of the decision managers against the thesis's"
        )
        fig.tight_layout()
        path = out_dir / f"figure_{figure.number.replace('.', '_')}_{figure.metric}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def _accuracy_curves(rows: list[dict], out_dir: Path, t: dict) -> list[Path]:
    """Table 4.2's accuracy against the items, one colour per belt speed."""
    fig, ax = plt.subplots(figsize=(6, 4))
    styles = ("-o", "-s", "-^", "-v")
    for i, factor in enumerate(t["speed_factors"]):
        colour = f"C{i}"
        at = _at_speed(rows, factor)
        for planner, style in zip(planners_of(rows), styles, strict=False):
            xs, groups = series(at, planner, column_value("accuracy"))
            if xs:
                means = [sum(g) / len(g) for g in groups]
                label = f"x{factor:g} {LABELS.get(planner, planner + ' (here)')}"
                ax.plot(xs, means, style, color=colour, label=label)
        ax.plot(
            t["items"],
            t["accuracy"][i],
            "--x",
            color=colour,
            alpha=0.6,
            label=f"x{factor:g} thesis: its Q-learning",
        )
    ax.set_xlabel("items per ~90 s")
    ax.set_ylabel("pick and place accuracy (SP/SI)")
    ax.set_title("Table 4.2: accuracy vs items and belt speed")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = out_dir / "table_4_2_accuracy.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def save_figures(table_id: str | None, rows: list[dict], out_dir: Path) -> list[Path]:
    """PNG figures 4.4-4.6 (tables 4.5/4.6) or accuracy curves (4.2) in `out_dir`; their paths."""
    if not rows:
        return []
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if table_id in ("4.5", "4.6"):
        return _decision_figures(rows, out_dir, thesis_tables())
    if table_id == "4.2":
        return _accuracy_curves(rows, out_dir, thesis_tables()["4.2"])
    return []


def main(argv: list[str] | None = None) -> int:
    """Figures 4.4-4.6 with both speeds: `python -m sim.experiments.thesis.thesis_report DIR...
    --out DIR`."""
    import argparse

    from sim.results import outputs

    parser = argparse.ArgumentParser(
        prog="python -m sim.experiments.thesis.thesis_report", description=main.__doc__
    )
    parser.add_argument("dirs", nargs="+", type=Path, help="sweep folders with episodes.csv")
    parser.add_argument("--out", type=Path, required=True, help="where to write the PNGs")
    args = parser.parse_args(argv)
    rows = [r for d in args.dirs for r in outputs.read_rows(d / "episodes.csv")]
    for path in save_figures("4.5", rows, args.out):
        print(f"figure: {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
