"""Tables 4.5 and 4.6 in the `calibrated` regime: the robot's pauses set so that proximity picks
as many items per second on table 4.5's flows as the thesis's proximity picker did.

The thesis's items per second come from its own columns
(`sim.experiments.thesis.thesis_rates`); ours are items picked over the simulated seconds until
the last item left the belt, per episode, averaged over the seeds and then over the datasets.
Each block prints both, dataset by dataset, so the calibration is checked wherever the block is
regenerated. The five decision managers (`qlearning`, `rollout`, `lookahead`, `proximity`,
`random`) run in one sweep a table.
"""

from __future__ import annotations

import statistics
from typing import TYPE_CHECKING

from sim.experiments.thesis import reproduce_tables as tables
from sim.experiments.thesis.reproduce_run import Block
from sim.experiments.thesis.thesis_rates import CALIBRATION_TOLERANCE, items_per_s
from sim.experiments.thesis.thesis_report import thesis_tables

if TYPE_CHECKING:
    from sim.experiments.thesis.reproduce_run import Run

REGIME = "calibrated"
"""The regime's name in the blocks, sweeps (`reproduce_4_5_calibrated`) and pieces."""
SWEEPS = ("reproduce_4_5_calibrated", "reproduce_4_6_calibrated")
PLANNERS = ("qlearning", "rollout", "lookahead", "proximity", "random")
COLUMNS = tables.DecisionColumns(
    planners=PLANNERS,
    comparisons=(
        ("qlearning", "proximity"),
        ("rollout", "proximity"),
        ("lookahead", "proximity"),
        ("random", "proximity"),
        ("qlearning", "random"),
    ),
    extra_sweeps=(),
    note=(
        "Each cell: qlearning / rollout / lookahead / proximity / random, ours (the thesis's). "
        '`qlearning` is the thesis\'s Q-learning as written (its "Our Method"), `rollout` and '
        "`lookahead` ours (no thesis counterpart), `proximity` the thesis's comparison picker, "
        '`random` the thesis\'s "random picker" (a uniform draw among the items the cup can '
        "meet now); means over the seeds."
    ),
)


def pauses_text(run: Run, sweep: str) -> str:
    """The pauses the sweep's episodes ran with: 'pauses 0.08 s after each pick and place'."""
    robots = {
        (r.pick_pause_s, r.place_pause_s)
        for s in run.sweep(sweep).episodes
        for r in s.config.robots
    }
    text = "; ".join(
        f"{pick:g} s after each pick, {place:g} s after each place"
        for pick, place in sorted(robots)
    )
    return f"pauses {text}"


def our_items_per_s(rows: list[dict], planner: str, items: list[int]) -> list[float | None]:
    """`planner`'s items picked per simulated second at each of `items`, mean over its
    episodes (None where it has none)."""
    by = tables.groups(rows, "n_items", "planner")
    out: list[float | None] = []
    for n in items:
        got = by.get((n, planner), [])
        rates = [float(r["picked"]) / float(r["sim_s"]) for r in got]
        out.append(statistics.fmean(rates) if rates else None)
    return out


def calibration_lines(rows: list[dict], t: dict) -> list[str]:
    """The check: proximity's items picked per second, ours (the thesis's) per dataset, and
    the means over the datasets with ours relative to the thesis's."""
    theirs = items_per_s(t, "proximity")
    ours = our_items_per_s(rows, "proximity", t["items"])
    cells = [
        "-" if o is None else f"{o:.3f} ({th:.3f})" for o, th in zip(ours, theirs, strict=True)
    ]
    lines = [
        "| items | " + " | ".join(str(n) for n in t["items"]) + " | mean |",
        "|---|" + "---|" * (len(t["items"]) + 1),
    ]
    known = [o for o in ours if o is not None]
    if len(known) < len(ours):
        return [*lines, "| proximity, items/s | " + " | ".join(cells) + " | - |"]
    mine, target = statistics.fmean(known), statistics.fmean(theirs)
    off = 100.0 * (mine / target - 1.0)
    inside = "within" if abs(off) <= 100 * CALIBRATION_TOLERANCE else "OUTSIDE"
    return [
        *lines,
        "| proximity, items/s | " + " | ".join(cells) + f" | {mine:.3f} ({target:.3f}) |",
        "",
        f"Calibration: proximity picks {mine:.3f} items/s on the mean over the datasets against "
        f"the thesis's {target:.3f} ({off:+.1f} %, {inside} the "
        f"{100 * CALIBRATION_TOLERANCE:.0f} % the regime is set to).",
    ]


def _table(run: Run, sweep: str, table: str, piece: str) -> Block:
    regime = f"the calibrated regime ({pauses_text(run, sweep)})"
    block = tables.decision_table(run, sweep, table, piece, regime, COLUMNS)
    t = thesis_tables()[table]
    check = calibration_lines(run.rows(sweep), t)
    head = "Items picked per second of simulated time (the thesis's: picked over its Time):"
    return Block("\n".join([block.markdown, "", head, "", *check]))


def table_4_5_calibrated(run: Run) -> Block:
    """Table 4.5 (x1) in the calibrated regime, with the calibration's check."""
    return _table(run, SWEEPS[0], "4.5", "table_4_5_calibrated")


def table_4_6_calibrated(run: Run) -> Block:
    """Table 4.6 (x1.2) in the calibrated regime (the pauses of table 4.5's calibration)."""
    return _table(run, SWEEPS[1], "4.6", "table_4_6_calibrated")
