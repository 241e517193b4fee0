"""The bound on tables 4.5 and 4.6's flows (`sortsim reproduce --only bound_4_5_4_6`).

Per regime (physical cycle, the thesis's pauses, calibrated) and table, dataset by dataset:

- the bound: the most any pick order can earn on the flow under the cycle-time model
  (`planner.decision.flow_bound`, computed per flow and seed from the sweep's configs by
  `sim.evaluation.flow_bound.bound_of`; no physics). It is not proven for the physics' robot,
  which may beat the model's least times somewhere: each table counts the physics runs that
  earned more than their flow's bound;
- the best known order: the planner `best_order` (the order the look-ahead planner finds with
  the whole flow known, followed in physics), a sweep of its own per regime and table;
- qlearning, rollout, lookahead, proximity and random from the regime's sweeps ("not run" where
  the regime has no sweep of a planner);
- the headroom of the bound and of the best known order over proximity, paired by flow (dataset
  and seed): the mean of 100 (a - b) / b [%] with the report's paired 95 % interval
  (`reproduce_paired.gain`, `reporting.stats.paired_difference`), per dataset and pooled.
"""

from __future__ import annotations

import statistics
from typing import TYPE_CHECKING

from sim.experiments.thesis import reproduce_paired as paired
from sim.experiments.thesis.reproduce_run import Block

if TYPE_CHECKING:
    from sim.config import EpisodeConfig
    from sim.experiments.thesis.reproduce_run import Run

PIECE = "bound_4_5_4_6"
BOUND = "bound"
"""The bound's rows' planner name."""
BEST = "best_order"
PLANNERS = ("qlearning", "rollout", "lookahead", "proximity", "random")
"""The decision managers beside the bound and the best known order, as far as a regime ran them."""
REGIMES = (
    ("physical cycle", "4.5", ("reproduce_4_5", "reproduce_4_5_random")),
    ("physical cycle", "4.6", ("reproduce_4_6", "reproduce_4_6_random")),
    ("the thesis's pauses", "4.5", ("reproduce_4_5_paused", "reproduce_4_5_paused_random")),
    ("the thesis's pauses", "4.6", ("reproduce_4_6_paused", "reproduce_4_6_paused_random")),
    ("calibrated", "4.5", ("reproduce_4_5_calibrated",)),
    ("calibrated", "4.6", ("reproduce_4_6_calibrated",)),
)
"""(regime, thesis table, the sweeps of its planners' rows), truth perception."""


def best_sweep(planner_sweeps: tuple[str, ...]) -> str:
    """The best known order's sweep of a regime and table: its first sweep's, `_best_order`."""
    return f"{planner_sweeps[0]}_best_order"


def sweeps() -> tuple[str, ...]:
    """Every sweep the piece reads: each regime's planners' and its best order's."""
    return tuple(s for _, _, names in REGIMES for s in (*names, best_sweep(names)))


def bound_row(config: EpisodeConfig) -> dict:
    """The bound on `config`'s flow as an episodes.csv-like row (planner `BOUND`)."""
    from sim.evaluation.flow_bound import bound_of, flow_facts

    bound = bound_of(flow_facts(config))
    return {
        "planner": BOUND,
        "n_items": config.items,
        "seed": str(config.seed),
        "profit_eur": bound.bound,
    }


def bound_rows(run: Run, sweep: str) -> list[dict]:
    """The bound on each flow of `sweep` as the run runs it (its seeds), one row a flow."""
    flows = {(s.config.items, s.config.seed): s.config for s in run.sweep(sweep).episodes}
    return [bound_row(config) for _, config in sorted(flows.items())]


def _mean_cell(rows: list[dict], planner: str, n: int, ran: set[str]) -> str:
    if planner not in ran:
        return "not run"
    got = [
        float(r["profit_eur"]) for r in rows if r["planner"] == planner and int(r["n_items"]) == n
    ]
    return f"{statistics.fmean(got):.2f}" if got else "-"


def above_bound(rows: list[dict]) -> tuple[int, int]:
    """(physics runs that earned more than their flow's bound, physics runs with a bound)."""
    bounds = {
        (int(r["n_items"]), str(r["seed"])): float(r["profit_eur"])
        for r in rows
        if r["planner"] == BOUND
    }
    physics = [r for r in rows if r["planner"] != BOUND]
    checked = [r for r in physics if (int(r["n_items"]), str(r["seed"])) in bounds]
    over = [
        r
        for r in checked
        if float(r["profit_eur"]) > bounds[int(r["n_items"]), str(r["seed"])] + 1e-9
    ]
    return len(over), len(checked)


def regime_table(rows: list[dict]) -> list[str]:
    """The table of one regime and belt from its rows (bound rows included): mean profit per
    dataset of each planner, and the paired headroom over proximity, per dataset and pooled."""
    columns = (BOUND, BEST, *PLANNERS)
    ran = {str(r["planner"]) for r in rows}
    items = sorted({int(r["n_items"]) for r in rows if r["planner"] == BOUND})
    headroom = {p: paired.pairs(rows, p, "proximity") for p in (BOUND, BEST)}
    lines = [
        "| items | " + " | ".join(columns) + " | bound - proximity | best order - proximity |",
        "|---|" + "---|" * (len(columns) + 2),
    ]
    for n in items:
        gains = [paired.gain(h[n]).text() if n in h else "-" for h in headroom.values()]
        means = [_mean_cell(rows, p, n, ran) for p in columns]
        lines.append(f"| {n} | " + " | ".join(means + gains) + " |")
    pooled = [
        paired.gain([f for n in sorted(h) for f in h[n]]).text() if h else "-"
        for h in headroom.values()
    ]
    lines.append("| pooled | " + " | ".join([""] * len(columns) + pooled) + " |")
    over, checked = above_bound(rows)
    lines += ["", f"Physics runs that earned more than their flow's bound: {over} of {checked}."]
    return lines


def bound_block(run: Run) -> Block:
    """The piece's block: a table per regime and belt."""
    from sim.experiments.thesis.thesis_report import thesis_tables

    tables = thesis_tables()
    text = [
        run.label(
            PIECE, run.seeds_text(*sweeps()) + ", truth perception; the bound per flow, no physics"
        ),
        "",
        "The bound is an upper bound under the cycle-time model, not proven for the physics' "
        "robot: the most any pick order can earn on the whole flow known in advance, for a robot "
        "that meets each item inside its reach window and takes at least the model's least pick "
        "and place times between meetings (`planner.decision.flow_bound`). Each table counts the "
        "physics runs that earned more than their flow's bound. `best_order`: the order the "
        "look-ahead planner finds with the whole flow known, replayed in physics (a lower bound "
        "on the best order's profit there). Profits [EUR], means over the seeds; headroom over "
        "proximity: the mean of 100 (a - b) / b per flow [%], paired by dataset and seed, "
        "[its 95 % interval] (the report's paired Student's t). \"not run\": the regime has no "
        "sweep of that planner.",
    ]
    for regime, table, names in REGIMES:
        rows = [r for s in names for r in run.rows(s)]
        rows += run.rows(best_sweep(names)) + bound_rows(run, best_sweep(names))
        speed = tables[table]["speed_factor"]
        text += ["", f"**{regime}, table {table} (x{speed:g})**", "", *regime_table(rows)]
    return Block("\n".join(text))
