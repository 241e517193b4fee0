"""Matplotlib figures in the style of the thesis's figures 4.4-4.6 (and a 4.2 curve plot).

Figures 4.4, 4.5 and 4.6 plot accuracy, time and profit against the dataset size for the
proximity picker and Q-learning, one panel per belt speed. Ours are solid lines with markers
(mean over seeds, bars at min..max), the thesis's dashed.
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
_COLOURS = {"proximity": "tab:orange", "qlearning": "tab:blue"}


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
            for planner in ("proximity", "qlearning"):
                xs, groups = _series(rows, planner, factor, column)
                if xs:
                    m = [sum(g) / len(g) for g in groups]
                    lo = [a - min(g) for a, g in zip(m, groups, strict=True)]
                    hi = [max(g) - a for a, g in zip(m, groups, strict=True)]
                    ax.errorbar(
                        xs,
                        m,
                        yerr=[lo, hi],
                        marker="o",
                        capsize=3,
                        color=_COLOURS[planner],
                        label=f"{planner} (ours)",
                    )
                t = thesis.get(factor)
                if t is not None:
                    ax.plot(
                        t["items"],
                        t[f"{metric}_{planner}"],
                        "--",
                        marker="x",
                        color=_COLOURS[planner],
                        alpha=0.6,
                        label=f"{planner} (thesis)",
                    )
            ax.set_title(f"({letter}) speed x{factor:g}")
            ax.set_xlabel("items in the dataset")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.suptitle(f"Figure {fig_id}: {metric}, proximity picker vs Q-learning")
        fig.tight_layout()
        path = out_dir / f"figure_{fig_id.replace('.', '_')}_{metric}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def _accuracy_curves(rows: list[dict], out_dir: Path, t: dict) -> list[Path]:
    fig, ax = plt.subplots(figsize=(6, 4))
    for i, factor in enumerate(t["speed_factors"]):
        xs, groups = _series(rows, "qlearning", factor, "accuracy")
        colour = f"C{i}"
        if xs:
            ax.plot(
                xs, [sum(g) / len(g) for g in groups], "-o", color=colour, label=f"x{factor:g} ours"
            )
        ax.plot(
            t["items"],
            t["accuracy"][i],
            "--x",
            color=colour,
            alpha=0.6,
            label=f"x{factor:g} thesis",
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
