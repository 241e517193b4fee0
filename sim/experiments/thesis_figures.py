"""Matplotlib figures in the style of the thesis's figures 4.4-4.6 (and a 4.2 curve plot).

Figures 4.4, 4.5 and 4.6 plot accuracy, time and profit against the dataset size for every
decision manager of the sweep, one panel per belt speed. Ours are solid lines with markers
(mean over seeds, bars at min..max), the thesis's dashed. The legend names each line for what
it is: `qlearning` the thesis's algorithm as written, run here; `rollout` ours (a sweep folder
written before the rename holds the rollout under the name `qlearning`: `docs/results.md`).
`sortsim reproduce` draws the chapter's figures from several sweeps
(`sim.experiments.reproduce_figures`).
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

_METRICS = (
    ("4.4", "accuracy", "accuracy", "Accuracy (SP/SI)"),
    ("4.5", "time", "sim_s", "Time [s]"),
    ("4.6", "profit", "profit_eur", "Profit [EUR]"),
)
_COLOURS = {"proximity": "tab:orange", "qlearning": "tab:blue", "rollout": "tab:green"}
LABELS = {
    "qlearning": "qlearning: the thesis's algorithm as written (here)",
    "rollout": "rollout: ours (here)",
    "proximity": "proximity (here)",
}
"""Legend of our lines by planner (another planner: its name and "(here)")."""
THESIS_LABELS = {"qlearning": "thesis: its Q-learning", "proximity": "thesis: proximity"}
"""Legend of the thesis's dashed lines."""


def mean_and_range(groups: list[list[float]]) -> tuple[list[float], list[float], list[float]]:
    """Each group's mean and its distances down to the group's minimum and up to its maximum,
    as error bars (never negative: the mean of equal values may round past them)."""
    m = [sum(g) / len(g) for g in groups]
    lo = [max(0.0, a - min(g)) for a, g in zip(m, groups, strict=True)]
    hi = [max(0.0, max(g) - a) for a, g in zip(m, groups, strict=True)]
    return m, lo, hi


def _planners(rows: list[dict]) -> list[str]:
    """The sweep's planners, the thesis's two first."""
    names = {r["planner"] for r in rows}
    return sorted(names, key=lambda p: (p not in ("proximity", "qlearning"), p))


def _series(rows: list[dict], planner: str, factor: float, column: str):
    by_items: dict[int, list[float]] = defaultdict(list)
    for row in rows:
        if row["planner"] == planner and abs(float(row["speed_factor"]) - factor) < 1e-6:
            by_items[int(row["n_items"])].append(float(row[column]))
    xs = sorted(by_items)
    return xs, [by_items[x] for x in xs]


def _comparison(rows: list[dict], out_dir: Path, tables: dict) -> list[Path]:
    factors = sorted({round(float(r["speed_factor"]), 3) for r in rows})
    thesis = {round(tables[k]["speed_factor"], 3): tables[k] for k in ("4.5", "4.6")}
    paths = []
    for fig_id, metric, column, label in _METRICS:
        fig, axes = plt.subplots(1, len(factors), figsize=(5.5 * len(factors), 4), squeeze=False)
        for ax, factor, letter in zip(axes[0], factors, "abcdef", strict=False):
            for planner in _planners(rows):
                xs, groups = _series(rows, planner, factor, column)
                if xs:
                    m, lo, hi = mean_and_range(groups)
                    ax.errorbar(
                        xs,
                        m,
                        yerr=[lo, hi],
                        marker="o",
                        capsize=3,
                        color=_COLOURS.get(planner),
                        label=LABELS.get(planner, f"{planner} (here)"),
                    )
                t = thesis.get(factor)
                if t is not None and planner in THESIS_LABELS:
                    ax.plot(
                        t["items"],
                        t[f"{metric}_{planner}"],
                        "--",
                        marker="x",
                        color=_COLOURS[planner],
                        alpha=0.6,
                        label=THESIS_LABELS[planner],
                    )
            ax.set_title(f"({letter}) speed x{factor:g}")
            ax.set_xlabel("items in the dataset")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.suptitle(f"Figure {fig_id}: {metric} of the decision managers against the thesis's")
        fig.tight_layout()
        path = out_dir / f"figure_{fig_id.replace('.', '_')}_{metric}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def _accuracy_curves(rows: list[dict], out_dir: Path, t: dict) -> list[Path]:
    fig, ax = plt.subplots(figsize=(6, 4))
    styles = ("-o", "-s", "-^", "-v")
    for i, factor in enumerate(t["speed_factors"]):
        colour = f"C{i}"
        for planner, style in zip(_planners(rows), styles, strict=False):
            xs, groups = _series(rows, planner, factor, "accuracy")
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


def figures_for(table_id: str | None, rows: list[dict], out_dir: Path, tables: dict) -> list[Path]:
    """Save the figures that fit `table_id` into `out_dir`; returns their paths."""
    if not rows:
        return []
    out_dir.mkdir(parents=True, exist_ok=True)
    if table_id in ("4.5", "4.6"):
        return _comparison(rows, out_dir, tables)
    if table_id == "4.2":
        return _accuracy_curves(rows, out_dir, tables["4.2"])
    return []
