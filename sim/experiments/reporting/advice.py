"""A purchase's answer from a sweep of lines: which lines meet a plant's targets with 95 %
confidence, the cheapest of them, its profit per hour and payback, and the runner-up.

A **line** is a robot count at a belt speed through one perception (`Line`). A **target** is a
level a metric of each episode must reach (`Target`): `recovery.<material>` (the share of the
material's items that entered and ended in its own bin), `recovery` (every material's),
`purity.<material>` (its bin's own material's share) or `purity` (every bin's). A line
**meets** a target when the lower end of the 95 % Student-t interval of the metric's mean over
its seeds reaches the level, **fails** it when the upper end is below it, and is **open**
otherwise (more seeds decide it). A line meets the targets when it meets each, fails when it
fails any.

The answer is read from the lines through the decision's perception (the camera when the sweep
ran it: what a real line sees; truth is the bound beside it): the cheapest line that meets the
targets (fewest robots, then the most profit per hour after the robots' cost), and the next
one. Its payback is the line's capital over a year's profit (net of energy) less maintenance:
`sim.results.economics.payback_years` over the whole line.

Pure functions of episodes.csv's rows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim.errors import InvalidInput
from sim.experiments.reporting.stats import estimate, number
from sim.results.economics import payback_years

TARGET_KINDS = ("recovery", "purity")
"""What a target may hold to a level: recovery and purity, per material or every material."""
MEETS, FAILS, OPEN = "meets", "fails", "open"


@dataclass(frozen=True)
class Target:
    """A level an episode's metric must reach: `kind` of `material` (None: every material)."""

    kind: str
    material: str | None
    level: float

    @property
    def name(self) -> str:
        return self.kind if self.material is None else f"{self.kind}.{self.material}"

    def value(self, row: dict, materials: tuple[str, ...]) -> float | None:
        """The episode's metric: the material's, or the lowest of every material's (a bin
        left empty or a material that never entered has none)."""
        names = materials if self.material is None else (self.material,)
        values = [number(row.get(f"{self.kind}_{m}")) for m in names]
        present = [v for v in values if v is not None]
        return min(present) if present else None


def parse_targets(text: str, materials: tuple[str, ...]) -> tuple[Target, ...]:
    """`recovery.aluminium=0.9,purity=0.95` as targets, or refused in one line.

    Args:
        text: Comma-separated `kind[.material]=level` entries, level in (0, 1].
        materials: The catalogue's material names.

    Returns:
        The targets, in the order given.

    Raises:
        InvalidInput: `--targets`, naming what is allowed.
    """
    kinds = " | ".join(f"{k}[.{'|'.join(materials)}]" for k in TARGET_KINDS)
    allowed = f"comma-separated {kinds}=LEVEL, LEVEL in (0, 1], each at most once"
    out: list[Target] = []
    for entry in (e.strip() for e in text.split(",")):
        name, _, level = entry.partition("=")
        kind, _, material = name.strip().partition(".")
        try:
            value = float(level)
        except ValueError:
            raise InvalidInput("--targets", allowed, entry) from None
        good = kind in TARGET_KINDS and (material == "" or material in materials)
        if not good or not 0.0 < value <= 1.0 or any(t.name == name.strip() for t in out):
            raise InvalidInput("--targets", allowed, entry)
        out.append(Target(kind, material or None, value))
    return tuple(out)


@dataclass(frozen=True, order=True)
class Line:
    """A line the sweep ran: robots, belt speed [m/s], perception."""

    robots: int
    belt_speed_mps: float
    perception: str

    @property
    def name(self) -> str:
        return f"{self.robots} x IRB 360 at {self.belt_speed_mps:.3f} m/s, {self.perception}"


def line_of(row: dict) -> Line:
    """The line an episode ran on (episodes.csv's `robots`, `belt_speed_mps`, `perception`)."""
    robots = int(row.get("robots") or 1)
    return Line(robots, round(float(row["belt_speed_mps"]), 4), row["perception"])


@dataclass(frozen=True)
class TargetResult:
    """A target's mean over a line's seeds, its 95 % interval and the verdict."""

    target: Target
    mean: float
    low: float
    high: float
    verdict: str

    def text(self) -> str:
        if math.isnan(self.mean):
            return "-"
        if math.isnan(self.low):
            return f"{self.mean:.3f} ({self.verdict})"
        return f"{self.mean:.3f} [{self.low:.3f}, {self.high:.3f}] ({self.verdict})"


def judged(target: Target, values: list[float]) -> TargetResult:
    """A target judged on a line's episodes' values (fewer than 2: open)."""
    if not values:
        return TargetResult(target, math.nan, math.nan, math.nan, OPEN)
    est = estimate(values)
    if est.n < 2 or math.isnan(est.half_width):
        return TargetResult(target, est.mean, math.nan, math.nan, OPEN)
    low, high = est.mean - est.half_width, est.mean + est.half_width
    verdict = MEETS if low >= target.level else FAILS if high < target.level else OPEN
    return TargetResult(target, est.mean, low, high, verdict)


@dataclass(frozen=True)
class LineResult:
    """A line's seeds, its targets' results, its money per hour and payback."""

    line: Line
    seeds: int
    results: tuple[TargetResult, ...]
    profit_per_h_eur: float
    net_profit_per_h_eur: float
    payback_years: float

    @property
    def verdict(self) -> str:
        verdicts = {r.verdict for r in self.results}
        return FAILS if FAILS in verdicts else OPEN if OPEN in verdicts else MEETS


def _mean(rows: list[dict], column: str) -> float:
    values = [v for v in (number(r.get(column)) for r in rows) if v is not None]
    return sum(values) / len(values) if values else math.nan


def line_result(
    line: Line, rows: list[dict], targets: tuple[Target, ...], materials: tuple[str, ...]
) -> LineResult:
    """A line judged on its episodes' rows."""
    results = tuple(
        judged(t, [v for v in (t.value(r, materials) for r in rows) if v is not None])
        for t in targets
    )
    profit = _mean(rows, "profit_per_h_eur")
    cost = _mean(rows, "robot_cost_per_h_eur")
    capital = line.robots * _mean(rows, "robot_capital_eur")
    maintenance = line.robots * _mean(rows, "robot_maintenance_eur_per_year")
    years = payback_years(capital, profit, _mean(rows, "hours_per_year"), maintenance)
    return LineResult(line, len(rows), results, profit, profit - cost, years)


def line_results(
    rows: list[dict], targets: tuple[Target, ...], materials: tuple[str, ...]
) -> list[LineResult]:
    """Every line of the rows, judged, in (robots, belt speed, perception) order."""
    by_line: dict[Line, list[dict]] = {}
    for row in rows:
        by_line.setdefault(line_of(row), []).append(row)
    return [line_result(k, by_line[k], targets, materials) for k in sorted(by_line)]


def deciding_perception(results: list[LineResult]) -> str:
    """The perception the answer is read from: the camera's when the sweep ran it."""
    return "camera" if any(r.line.perception == "camera" for r in results) else "truth"


def ranked(results: list[LineResult], perception: str | None = None) -> list[LineResult]:
    """The lines of `perception` (None: the deciding one) that meet the targets, cheapest
    first (fewest robots, then the most profit per hour after the robots' cost)."""
    perception = perception or deciding_perception(results)
    meeting = [r for r in results if r.line.perception == perception and r.verdict == MEETS]
    return sorted(meeting, key=lambda r: (r.line.robots, -r.net_profit_per_h_eur))


def decided(results: list[LineResult]) -> bool:
    """Whether more seeds could change the answer: every line of the deciding perception
    with no more robots than the cheapest meeting one (every line, when none meets yet) is
    decided."""
    perception = deciding_perception(results)
    best = ranked(results)
    most = best[0].line.robots if best else math.inf
    return all(
        r.verdict != OPEN
        for r in results
        if r.line.perception == perception and r.line.robots <= most
    )


def _years(years: float) -> str:
    return "never" if math.isinf(years) or math.isnan(years) else f"{years:.1f}"


def table(results: list[LineResult]) -> str:
    """The lines as a markdown table: seeds, each target, money per hour, payback, verdict."""
    if not results:
        return "(no episode)"
    names = [r.target.name for r in results[0].results]
    head = ["line", "seeds", *names, "profit/h", "after robots/h", "payback years", "verdict"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in results:
        cells = [r.line.name, str(r.seeds), *(t.text() for t in r.results)]
        cells += [f"{r.profit_per_h_eur:.2f}", f"{r.net_profit_per_h_eur:.2f}"]
        cells += [_years(r.payback_years), r.verdict]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def recommendation(results: list[LineResult], targets: tuple[Target, ...]) -> str:
    """The answer in words: the cheapest line meeting the targets and the runner-up."""
    wanted = ", ".join(f"{t.name} >= {t.level:g}" for t in targets)
    perception = deciding_perception(results)
    best = ranked(results)
    if not best:
        still = "; some lines are still open: more seeds decide" if not decided(results) else ""
        text = f"No line meets {wanted} with 95 % confidence through {perception}{still}."
        return text + _bound_text(results, perception)
    first = best[0]
    text = (
        f"Recommended: {first.line.name}: meets {wanted} with 95 % confidence; "
        f"{first.profit_per_h_eur:.2f} EUR/h net of energy, {first.net_profit_per_h_eur:.2f} "
        f"after the robots' cost; pays back in {_years(first.payback_years)} years."
    )
    if len(best) > 1:
        second = best[1]
        text += (
            f"\nRunner-up: {second.line.name}: {second.profit_per_h_eur:.2f} EUR/h, "
            f"{second.net_profit_per_h_eur:.2f} after the robots' cost, pays back in "
            f"{_years(second.payback_years)} years."
        )
    return text + _bound_text(results, perception)


def _bound_text(results: list[LineResult], perception: str) -> str:
    """Beside a camera's answer, the cheapest line that meets the targets with truth's
    perfect perception (the bound of what a better camera could give)."""
    bound = ranked(results, "truth") if perception == "camera" else []
    if not bound:
        return ""
    return (
        f"\nWith perfect perception (truth, the bound): {bound[0].line.name}, "
        f"{bound[0].net_profit_per_h_eur:.2f} EUR/h after the robots' cost."
    )
