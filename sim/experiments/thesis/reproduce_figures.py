"""The figures of `sortsim reproduce`: the thesis's 4.2 and 4.4-4.9 from the current code.

Figures 4.4-4.9 are one PNG each of four panels: the robot's physical cycle (top) and the
thesis's pauses (bottom), belt x1 (left) and x1.2 (right); against the dataset's size, one
solid line per decision manager (mean over the seeds, bars from the least to the most) and,
for accuracy, time and profit, the thesis's two dashed (its proximity picker and its
Q-learning). Legends say which line is which: `qlearning` the thesis's algorithm as written,
`rollout` ours. Figure 4.2 compares the three objectives of the Q-learning reward.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from sim.experiments.thesis.reproduce_run import Block  # noqa: E402
from sim.experiments.thesis.reproduce_tables import PLANNERS  # noqa: E402
from sim.experiments.thesis.thesis_report import (  # noqa: E402
    DECISION_FIGURES,
    DecisionFigure,
    RowValue,
    column_value,
    decision_panel,
    thesis_tables,
)

if TYPE_CHECKING:
    from pathlib import Path

    from sim.experiments.thesis.reproduce_run import Run

SWEEPS = (
    ("physical cycle", "reproduce_4_5", "4.5"),
    ("physical cycle", "reproduce_4_6", "4.6"),
    ("the thesis's pauses", "reproduce_4_5_paused", "4.5"),
    ("the thesis's pauses", "reproduce_4_6_paused", "4.6"),
)
"""The four panels of figures 4.4-4.9: (regime, sweep, the thesis's table at its speed)."""


def _per_class(material: str) -> RowValue:
    def value(row: dict) -> float | None:
        entered = float(row.get(f"entered_{material}") or 0)
        return float(row[f"picked_{material}"]) / entered if entered else None

    return value


def _panels(
    run: Run, name: str, title: str, ylabel: str, value: RowValue, thesis_metric: str | None
) -> Block:
    """A 2 x 2 figure (regime x belt speed) of `value` against the dataset's size."""
    tables = thesis_tables()
    fig, axes = plt.subplots(2, 2, figsize=(11, 8), sharex=True)
    for ax, (regime, sweep, table), letter in zip(axes.flat, SWEEPS, "abcd", strict=True):
        t = tables[table]
        decision_panel(ax, run.rows(sweep), PLANNERS, value, t, thesis_metric)
        ax.set_title(f"({letter}) belt x{t['speed_factor']:g}, {regime}")
        ax.set_ylabel(ylabel)
    for ax in axes.flat:  # the legend once, on the first panel that has lines
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
            break
    seeds = run.seeds_text(*(s for _, s, _ in SWEEPS))
    assert run.figures is not None  # set by Run
    path = _saved(
        fig,
        f"{title}\n{run.command}{' --quick' if run.quick else ''}: {seeds}, truth perception",
        run.figures / f"{name}.png",
    )
    what = seeds + ", truth perception; top: physical cycle, bottom: the thesis's pauses"
    text = "\n".join([run.label(name, what), "", run.figure(path, title)])
    return Block(text, (path,))


def _decision_figure(run: Run, figure: DecisionFigure) -> Block:
    name = f"figure_{figure.number.replace('.', '_')}"
    title = f"Figure {figure.number}: {figure.metric}"
    if figure.metric == "accuracy":
        title += " (SP/SI)"
    value = column_value(figure.column)
    return _panels(run, name, title, figure.ylabel, value, figure.metric)


def figure_4_4(run: Run) -> Block:
    """Figure 4.4: accuracy SP/SI against the dataset's size."""
    return _decision_figure(run, DECISION_FIGURES[0])


def figure_4_5(run: Run) -> Block:
    """Figure 4.5: time (simulated, until the last item left the belt)."""
    return _decision_figure(run, DECISION_FIGURES[1])


def figure_4_6(run: Run) -> Block:
    """Figure 4.6: profit."""
    return _decision_figure(run, DECISION_FIGURES[2])


def figure_4_7(run: Run) -> Block:
    """Figure 4.7: accuracy of class 2 (paper), picked over entered."""
    return _panels(
        run,
        "figure_4_7",
        "Figure 4.7: accuracy of class 2 (paper)",
        "paper picked / entered",
        _per_class("paper"),
        None,
    )


def figure_4_8(run: Run) -> Block:
    """Figure 4.8: accuracy of class 3 (plastic)."""
    return _panels(
        run,
        "figure_4_8",
        "Figure 4.8: accuracy of class 3 (plastic)",
        "plastic picked / entered",
        _per_class("plastic"),
        None,
    )


def figure_4_9(run: Run) -> Block:
    """Figure 4.9: accuracy of class 4 (aluminium)."""
    return _panels(
        run,
        "figure_4_9",
        "Figure 4.9: accuracy of class 4 (aluminium)",
        "aluminium picked / entered",
        _per_class("aluminium"),
        None,
    )


OBJECTIVES = (
    ("v/d", "v_over_d", "v/d (eq. 3.3, the thesis's choice)"),
    ("d=1", "d_1", "d = 1 (values only)"),
    ("v=1", "v_1", "v = 1 (distance only)"),
)


def objective_numbers(run: Run) -> dict[str, dict[str, tuple[float, float]]]:
    """{setting: {objective: (accuracy, profit [EUR])}}: the planner level at x1 and x1.2
    (118-item belts in 45 s on the kinematic belt, `planner.decision.evaluation`), and episodes
    (`experiments/reproduce_objectives.toml`, the thesis's pauses)."""
    from planner.decision.evaluation import objective_variants
    from sim.episode.decision_view import cell_context

    belts = range(3 if run.quick else 10)
    out = {}
    for factor in (1.0, 1.2):
        variants = objective_variants(cell_context, belts, factor, planner="qlearning")
        out[f"planner level, x{factor:g} ({len(belts)} belts)"] = variants
    rows = run.rows("reproduce_objectives")
    episodes = {}
    for key, variant, _ in OBJECTIVES:
        mine = [r for r in rows if r.get("variant") == variant]
        if mine:
            acc = sum(float(r["accuracy"]) for r in mine) / len(mine)
            episodes[key] = (acc, sum(float(r["profit_eur"]) for r in mine) / len(mine))
    out["episodes, x1, pauses"] = episodes
    return out


def figure_4_2(run: Run) -> Block:
    """Figure 4.2: accuracy and profit of the three objectives, planner level and episodes."""
    numbers = objective_numbers(run)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    settings = list(numbers)
    width = 0.25
    for k, (key, _, label) in enumerate(OBJECTIVES):
        for ax, i in zip(axes, (0, 1), strict=True):
            xs = [s + (k - 1) * width for s in range(len(settings))]
            ys = [numbers[s].get(key, (0.0, 0.0))[i] for s in settings]
            ax.bar(xs, ys, width, label=label, color=f"C{k}")
    for ax, ylabel in zip(
        axes, ("accuracy (share of items picked)", "profit [EUR] per flow"), strict=True
    ):
        ax.set_xticks(range(len(settings)))
        ax.set_xticklabels([s.replace(", ", "\n", 1) for s in settings], fontsize=8)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3, axis="y")
    axes[0].legend(fontsize=8)
    seeds = run.seeds_text("reproduce_objectives")
    assert run.figures is not None  # set by Run
    path = _saved(
        fig,
        f"Figure 4.2: the three objectives, qlearning\n{run.command}"
        f"{' --quick' if run.quick else ''}: episodes {seeds}",
        run.figures / "figure_4_2.png",
    )
    lines = [
        "| setting | " + " | ".join(label for _, _, label in OBJECTIVES) + " |",
        "|---|---|---|---|",
    ]
    for s in settings:
        cells = [
            "-" if key not in numbers[s] else f"{numbers[s][key][0]:.3f} / {numbers[s][key][1]:.2f}"
            for key, _, _ in OBJECTIVES
        ]
        lines.append(f"| {s} | " + " | ".join(cells) + " |")
    what = (
        f"the kinematic belt (planner level: 118 items in 45 s) and episodes ({seeds}, 118 "
        "items over 90 s at x1, the thesis's pauses)"
    )
    text = [
        run.label("figure_4_2", what),
        "",
        "Cells: accuracy (share of the items picked) / profit [EUR] per flow, qlearning. The "
        "thesis (4.1.3): v = 1 the most accurate, d = 1 the most profitable, v/d between.",
        "",
        *lines,
        "",
        run.figure(path, "Figure 4.2: accuracy and profit of the three objectives"),
    ]
    return Block("\n".join(text), (path,))


FIGURE_4_3_BELT = 3
"""Seed of the busy belt (`planner.decision.evaluation.short_belt`) figure 4.3 plans on."""


def figure_4_3(run: Run) -> Block:
    """Figure 4.3: the pick-and-place paths of the three objectives on one busy belt."""
    from planner.decision.evaluation import short_belt
    from planner.decision.interface import THESIS_VALUES
    from planner.decision.kinematic_belt import THESIS_SPEED_X1, simulate
    from planner.decision.registry import make_planner
    from sim.episode.decision_view import cell_context

    belt = short_belt(FIGURE_4_3_BELT)
    context = cell_context(belt.speed, THESIS_VALUES)
    colours = {2: "tab:brown", 3: "tab:blue", 4: "tab:grey"}
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.6), sharey=True)
    rows = []
    for ax, (key, _, label) in zip(axes, OBJECTIVES, strict=True):
        result = simulate(make_planner("qlearning", objective=key), belt, context)
        items = {it.item_id: it for it in belt.items}
        route = [(0.0, 0.0)]
        for k, pick in enumerate(result.picks, start=1):
            item = items[pick.item_id]
            x, y = item.x0 + belt.speed * pick.meet, item.y
            bx, by, _ = context.bin_of(pick.bin_class)
            ax.scatter([x], [y], s=120, color=colours.get(pick.true_class, "k"), zorder=3)
            ax.annotate(str(k), (x, y), ha="center", va="center", fontsize=7, color="w", zorder=4)
            route += [(x, y), (bx, by)]
        for cls in sorted({it.true_class for it in belt.items}):
            bx, by, _ = context.bin_of(cls)
            ax.scatter([bx], [by], marker="s", s=90, color=colours.get(cls, "k"), edgecolors="k")
        xs, ys = zip(*route, strict=True)
        ax.plot(xs, ys, "-", color="k", alpha=0.35, lw=1)
        ax.set_title(
            f"{label}\n{len(result.picks)} of {len(belt.items)} picked, {result.profit:.2f} EUR",
            fontsize=9,
        )
        ax.set_xlabel("x along the belt where the cup meets the item [m]")
        ax.grid(alpha=0.3)
        ax.set_aspect("equal", adjustable="datalim")
        rows.append(f"| {label} | {len(result.picks)} of {len(belt.items)} | {result.profit:.2f} |")
    axes[0].set_ylabel("y across the belt [m]")
    assert run.figures is not None  # set by Run
    path = _saved(
        fig,
        f"Figure 4.3: qlearning's pick order (numbers) and path to each item's bin "
        f"(squares) on busy belt {FIGURE_4_3_BELT} (kinematic belt, x"
        f"{belt.speed / THESIS_SPEED_X1:.2g})",
        run.figures / "figure_4_3.png",
    )
    text = [
        run.label("figure_4_3", f"busy belt {FIGURE_4_3_BELT} of the planner-level benchmark"),
        "",
        "| objective | picked | profit [EUR] |",
        "|---|---|---|",
        *rows,
        "",
        run.figure(path, "Figure 4.3: the paths of the three objectives"),
    ]
    return Block("\n".join(text), (path,))


def _saved(fig, title: str, path: Path) -> Path:
    """`fig` under `title` (10 pt), written to `path` (PNG, 100 dpi) and closed; `path`."""
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
