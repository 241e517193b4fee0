"""A report's statistics: means with their 95 % intervals over the seeds, paired differences,
and the mark of an interval that rests on fewer than `FEW_SEEDS` seeds."""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass
from typing import Any

FEW_SEEDS = 3
"""An interval from fewer seeds is marked (`seeds_cell`) and explained under its table."""
FEW_SEEDS_MARK = "*"
FEW_SEEDS_NOTE = (
    f"{FEW_SEEDS_MARK} fewer than {FEW_SEEDS} seeds: no interval from one; from two, Student's "
    "t(0.975, 1) = 12.7 makes it too wide to decide anything. Run more seeds."
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


def number(text: Any) -> float | None:
    """A CSV cell as a finite number, None when it is empty or not one."""
    if text is None or text == "":
        return None
    try:
        value = float(text)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def seeds_cell(n: int) -> str:
    """A table's seed count, marked when fewer than `FEW_SEEDS`."""
    return str(n) if n >= FEW_SEEDS else f"{n}{FEW_SEEDS_MARK}"


def few_seeds_note(counts) -> str:
    """`FEW_SEEDS_NOTE` when any of `counts` is under `FEW_SEEDS`, else ""."""
    return FEW_SEEDS_NOTE if any(n < FEW_SEEDS for n in counts) else ""


def paired_difference(a: list[float], b: list[float]) -> tuple[float, float, float, float]:
    """(mean difference, interval low, interval high, p) of paired samples, a minus b.

    The 95 % interval is the paired Student's t one, mean ± t(0.975, n - 1) x sd / sqrt(n) of
    the per-pair differences, and p the two-sided p-value of `scipy.stats.ttest_rel(a, b)`.
    Differences all equal (sd 0) give an interval of no width and p 0 (1 when they are all 0);
    one pair gives no interval (nan).
    """
    from scipy import stats

    d = [x - y for x, y in zip(a, b, strict=True)]
    n = len(d)
    mean = statistics.fmean(d)
    if n < 2:
        return mean, math.nan, math.nan, math.nan
    sd = statistics.stdev(d)
    if sd == 0.0:
        return mean, mean, mean, (1.0 if mean == 0.0 else 0.0)
    half = float(stats.t.ppf(0.975, n - 1)) * sd / math.sqrt(n)
    p = float(stats.ttest_rel(a, b).pvalue)
    return mean, mean - half, mean + half, p
