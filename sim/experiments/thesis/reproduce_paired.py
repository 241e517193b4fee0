"""The +13 % finding with paired 95 % intervals (`sortsim reproduce --only finding_paired`).

Each comparison (qlearning, rollout and lookahead against proximity and against the random
picker) is paired by flow: the two planners ran the same dataset (item count) and seed. A pair's
gain is 100 (a - b) / b of their profits [%]; per dataset and pooled over the datasets, the mean
gain has the report's paired Student's t interval (`reporting.stats.paired_difference` of the
gains against 0: `scipy.stats.ttest_rel`'s test). The thesis's claim that the gain grows with
the number of items is the least-squares slope of the pairs' gain in EUR against the dataset's
item count, with its 95 % interval (Student's t, n - 2). The timing hypothesis is computed from
the thesis's own Time columns (`sim.experiments.thesis.thesis_rates.timing`).
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass
from typing import TYPE_CHECKING

from sim.experiments.reporting.stats import paired_difference
from sim.experiments.thesis.reproduce_run import Block
from sim.experiments.thesis.thesis_rates import timing
from sim.experiments.thesis.thesis_report import thesis_tables

if TYPE_CHECKING:
    from sim.experiments.thesis.reproduce_run import Run

PAIRINGS = (
    ("qlearning", "proximity"),
    ("rollout", "proximity"),
    ("lookahead", "proximity"),
    ("qlearning", "random"),
    ("rollout", "random"),
    ("lookahead", "random"),
)
"""(planner, against) of the finding's rows."""
REGIMES = (
    ("physical cycle", ("reproduce_4_5", "reproduce_4_5_random"), "4.5"),
    ("physical cycle", ("reproduce_4_6", "reproduce_4_6_random"), "4.6"),
    ("the thesis's pauses", ("reproduce_4_5_paused", "reproduce_4_5_paused_random"), "4.5"),
    ("the thesis's pauses", ("reproduce_4_6_paused", "reproduce_4_6_paused_random"), "4.6"),
    ("calibrated", ("reproduce_4_5_calibrated",), "4.5"),
    ("calibrated", ("reproduce_4_6_calibrated",), "4.6"),
)
"""(regime, the sweeps of its rows, thesis table) of the finding, truth perception."""

Pairs = dict[int, list[tuple[float, float]]]
"""(planner's profit, against's profit) [EUR] per item count, one pair per seed."""


@dataclass(frozen=True)
class Gain:
    """A mean paired gain [%] and its 95 % interval (nan with one pair)."""

    mean: float
    low: float
    high: float
    n: int

    def text(self) -> str:
        if math.isnan(self.low):
            return f"{self.mean:+.1f} % (n {self.n})"
        return f"{self.mean:+.1f} [{self.low:+.1f}, {self.high:+.1f}]"


@dataclass(frozen=True)
class Slope:
    """A least-squares slope and its 95 % interval (nan with fewer than 3 points)."""

    per_100: float
    low: float
    high: float
    n: int


def pairs(rows: list[dict], planner: str, against: str) -> Pairs:
    """The profits of `planner` and `against` on the same flow (item count and seed), by item
    count; flows only one of them ran are left out."""
    profit: dict[tuple[str, int, str], float] = {}
    for r in rows:
        profit[r["planner"], int(r["n_items"]), str(r["seed"])] = float(r["profit_eur"])
    out: Pairs = defaultdict(list)
    for (p, n, seed), value in sorted(profit.items(), key=lambda kv: (kv[0][1], int(kv[0][2]))):
        if p == planner and (against, n, seed) in profit:
            out[n].append((value, profit[against, n, seed]))
    return dict(out)


def gain(flows: list[tuple[float, float]]) -> Gain:
    """The mean of the pairs' gains 100 (a - b) / b [%] and its paired 95 % interval."""
    gains = [100.0 * (a - b) / b for a, b in flows]
    mean, low, high, _ = paired_difference(gains, [0.0] * len(gains))
    return Gain(mean, low, high, len(gains))


def slope(by_items: Pairs) -> Slope:
    """The slope of the pairs' gain a - b [EUR] against the item count, per 100 items, and its
    95 % interval (Student's t with n - 2 degrees of freedom)."""
    from scipy import stats

    xs = [float(n) for n, flows in by_items.items() for _ in flows]
    ys = [a - b for flows in by_items.values() for a, b in flows]
    if len(xs) < 3 or len(set(xs)) < 2:
        return Slope(math.nan, math.nan, math.nan, len(xs))
    fit = stats.linregress(xs, ys)
    half = float(stats.t.ppf(0.975, len(xs) - 2)) * fit.stderr
    return Slope(100.0 * fit.slope, 100.0 * (fit.slope - half), 100.0 * (fit.slope + half), len(xs))


def thesis_slope(t: dict) -> float:
    """The thesis's own slope of Q-learning's profit gain over proximity [EUR per 100 items]."""
    from scipy import stats

    gains = [a - b for a, b in zip(t["profit_qlearning"], t["profit_proximity"], strict=True)]
    return 100.0 * float(stats.linregress(t["items"], gains).slope)


def _slope_text(s: Slope) -> str:
    if math.isnan(s.low):
        return "-"
    return f"{s.per_100:+.2f} [{s.low:+.2f}, {s.high:+.2f}]"


def comparison_row(regime: str, speed: float, by_items: Pairs, label: str, items: list[int]) -> str:
    """One row of the finding's table: the gain at each of `items` ("-" where no pairs),
    pooled, and the slope of the gain against the item count."""
    cells = [gain(by_items[n]).text() if n in by_items else "-" for n in items]
    pooled = gain([f for n in sorted(by_items) for f in by_items[n]])
    return (
        f"| {regime} | x{speed:g} | {label} | "
        + " | ".join(cells)
        + f" | {pooled.text()} | {_slope_text(slope(by_items))} |"
    )


def _timing_lines(tables: dict) -> list[str]:
    lines = []
    for table in ("4.5", "4.6"):
        t = tables[table]
        tm = timing(t)
        lines.append(
            f"- table {table} (x{t['speed_factor']:g}): its Q-learning's Time was "
            f"{tm.longer_pct:+.1f} % longer than its proximity picker's, it picked "
            f"{tm.picked_pct:+.1f} % more items and {tm.rate_pct:+.1f} % more items per second "
            f"of its Time; its profit gain grew by {thesis_slope(t):+.2f} EUR per 100 items."
        )
    return lines


def finding_paired(run: Run) -> Block:
    """The finding's block: every pairing in every truth regime with its paired intervals, the
    slope of the gain against the item count, and the thesis's timing."""
    tables = thesis_tables()
    found = []
    for regime, sweeps, table in REGIMES:
        rows = [r for s in sweeps for r in run.rows(s)]
        for planner, against in PAIRINGS:
            by_items = pairs(rows, planner, against)
            if by_items:
                speed = tables[table]["speed_factor"]
                found.append((regime, speed, by_items, f"{planner} - {against}"))
    items = sorted({n for *_, by_items, _ in found for n in by_items})
    lines = [
        "| regime | belt | planner - against | "
        + " | ".join(f"{n} items" for n in items)
        + " | pooled | slope [EUR per 100 items] |",
        "|---|---|---|" + "---|" * (len(items) + 2),
        *(comparison_row(*f, items) for f in found),
    ]
    names = [s for _, sweeps, _ in REGIMES for s in sweeps]
    text = [
        run.label("finding_paired", run.seeds_text(*names) + ", truth perception"),
        "",
        "Each cell: the mean profit gain of the planner over the one it is against, 100 (a - b) "
        "/ b per flow [%], paired by dataset and seed, and [its 95 % interval] (the report's "
        "paired Student's t); pooled: over every flow of the regime and belt. Slope: the "
        "pairs' gain in EUR against the dataset's item count, least squares, per 100 items "
        "[95 % interval]; the thesis claims the gain grows with the items (a positive slope). "
        "`lookahead` ran in the calibrated regime only.",
        "",
        *lines,
        "",
        "The thesis's own columns (means over its datasets of the per-dataset ratios; Time as "
        "it kept it):",
        "",
        *_timing_lines(tables),
    ]
    return Block("\n".join(text))
