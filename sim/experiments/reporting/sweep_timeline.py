"""A sweep's timeline as figures (`sim.experiments.sweep_runner`'s timeline.csv): one per grid
point (variant, planner, belt speed, items), the mean over its seeds with their range.

Three panels share the time axis: picks per minute over the last minute (`WINDOW_S`: a 10 s
row holds too few picks to read), the profit so far, and the share of the seeds with a fault of
each kind active. Only the times every seed sampled are drawn (an episode's last row, at its
own end, is left out when the seeds end apart); the range is the lowest and the highest seed.
"""

from __future__ import annotations

import io
import statistics
from collections import defaultdict
from dataclasses import dataclass

from sim.config.faults import FAULT_KINDS
from sim.experiments.reporting.fault_colours import BAND_COLOURS

KEY_COLUMNS = ("variant", "planner", "speed_factor", "n_items")
"""The columns of a grid point; `seed` and the variants' settings (`variant.<key>`) aside."""
WINDOW_S = 60.0
"""The picks per minute of a row are those of the last `WINDOW_S` [s] before it."""


def is_sweep_timeline(rows: list[dict[str, str]]) -> bool:
    """Whether the rows are a sweep's (each led by its episode's key columns)."""
    return bool(rows) and "seed" in rows[0]


def by_point(rows: list[dict[str, str]]) -> dict[tuple[str, ...], dict[str, list[dict]]]:
    """{grid point (`KEY_COLUMNS` values): {seed: its rows, in order}}, in the file's order."""
    out: dict[tuple[str, ...], dict[str, list[dict]]] = defaultdict(lambda: defaultdict(list))
    for row in rows:
        out[tuple(row[c] for c in KEY_COLUMNS)][row["seed"]].append(row)
    return out


def recent_rates(rows: list[dict[str, str]], window_s: float = WINDOW_S) -> list[float]:
    """Each row's picks per minute over the last `window_s` [s] (from t = 0 for the first
    rows): picks since the latest row at least `window_s` before it, over the time between."""
    times = [0.0] + [float(r["t_s"]) for r in rows]
    picked = [0] + [int(r["picked"]) for r in rows]
    rates, start = [], 0
    for i in range(1, len(times)):
        while times[start + 1] <= times[i] - window_s:
            start += 1
        span = times[i] - times[start]
        rates.append(60.0 * (picked[i] - picked[start]) / span if span > 0 else 0.0)
    return rates


@dataclass(frozen=True)
class Band:
    """A quantity over the seeds at each time: its mean, lowest and highest."""

    mean: list[float]
    low: list[float]
    high: list[float]

    @classmethod
    def of(cls, columns: list[list[float]]) -> Band:
        """From one list of values per time (a value per seed)."""
        return cls(
            [statistics.fmean(c) for c in columns], [min(c) for c in columns],
            [max(c) for c in columns],
        )  # fmt: skip


@dataclass(frozen=True)
class PointTimeline:
    """A grid point's timeline over its seeds, at the times every seed sampled.

    Attributes:
        minutes: The times [min].
        seeds: How many seeds.
        rate: Picks per minute over the last minute.
        profit: Profit so far [EUR].
        fault_share: {fault kind: share of the seeds with it active [0, 1]} (kinds seen only).
    """

    minutes: list[float]
    seeds: int
    rate: Band
    profit: Band
    fault_share: dict[str, list[float]]


def point_timeline(seeds: dict[str, list[dict[str, str]]]) -> PointTimeline:
    """The timeline of one grid point from its seeds' rows (`by_point`)."""
    runs = list(seeds.values())
    common = set.intersection(*({r["t_s"] for r in rows} for rows in runs))
    times = sorted(common, key=float)
    rates, profit = [], []
    shares: dict[str, list[float]] = {}
    at = []  # per seed: {t_s: (row, picks per minute)}
    for run in runs:
        rated = zip(run, recent_rates(run), strict=True)
        at.append({r["t_s"]: (r, rate) for r, rate in rated})
    for t in times:
        sampled = [seed[t] for seed in at]
        rates.append([rate for _, rate in sampled])
        profit.append([float(r["profit_eur"]) for r, _ in sampled])
        kinds = [{f.split(" ")[0] for f in r["faults"].split("; ") if f} for r, _ in sampled]
        for kind in FAULT_KINDS:
            shares.setdefault(kind, []).append(sum(kind in k for k in kinds) / len(kinds))
    seen = {k: v for k, v in shares.items() if any(v)}
    minutes = [float(t) / 60.0 for t in times]
    return PointTimeline(minutes, len(runs), Band.of(rates), Band.of(profit), seen)


def point_png(timeline: PointTimeline, title: str) -> bytes:
    """The figure's PNG: picks per minute, profit so far, the seeds' faults."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, middle, bottom) = plt.subplots(
        3, 1, sharex=True, figsize=(6.4, 6.0), dpi=100, height_ratios=(3, 3, 1.6)
    )
    x = timeline.minutes
    for ax, band, colour, label in (
        (top, timeline.rate, "tab:blue", "picks per minute\n(last minute)"),
        (middle, timeline.profit, "tab:green", "profit so far [EUR]"),
    ):
        ax.fill_between(x, band.low, band.high, color=colour, alpha=0.2, linewidth=0)
        ax.plot(x, band.mean, color=colour, label=f"mean of {seeds_text(timeline.seeds)}")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    top.legend(fontsize=7, loc="lower right", title="shaded: lowest to highest seed",
               title_fontsize=7)  # fmt: skip
    top.set_title(title, fontsize=9)
    for kind, share in timeline.fault_share.items():
        bottom.step(x, [100.0 * s for s in share], where="pre", color=BAND_COLOURS[kind],
                    label=kind)  # fmt: skip
    bottom.set_ylim(-5, 105)
    bottom.set_ylabel("seeds with\nthe fault [%]")
    bottom.set_xlabel("simulated time [min]")
    bottom.grid(alpha=0.3)
    if timeline.fault_share:
        bottom.legend(fontsize=6, loc="upper right", ncol=2)
    else:
        bottom.text(0.5, 0.5, "no fault", transform=bottom.transAxes, ha="center", va="center")
    return _png(fig)


def overlay_png(timelines: dict[str, PointTimeline], title: str) -> bytes:
    """The grid points' profit so far in one figure (mean and range over the seeds each): what
    a variant gains or loses against another, over time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6), dpi=100)
    for name, timeline in timelines.items():
        band = timeline.profit
        (line,) = ax.plot(timeline.minutes, band.mean, label=name)
        ax.fill_between(timeline.minutes, band.low, band.high, color=line.get_color(),
                        alpha=0.2, linewidth=0)  # fmt: skip
    ax.set_title(title, fontsize=9)
    ax.set_ylabel("profit so far [EUR]")
    ax.set_xlabel("simulated time [min]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, title="mean; shaded: lowest to highest seed", title_fontsize=7)
    return _png(fig)


def _png(fig) -> bytes:
    """The figure as PNG bytes, closed."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    plt.close(fig)
    return buffer.getvalue()


def seeds_text(n: int) -> str:
    """'3 seeds', '1 seed'."""
    return f"{n} seed" if n == 1 else f"{n} seeds"


def point_name(point: tuple[str, ...], points: list[tuple[str, ...]]) -> str:
    """A grid point in words: its variant, planner, belt speed and items where the sweep's
    points differ in them (its planner when they differ in none)."""
    variant, planner, speed, items = point
    words = [variant] if len({p[0] for p in points}) > 1 else []
    words += [planner] if len({p[1] for p in points}) > 1 or not words else []
    words += [f"belt x{float(speed):g}"] if len({p[2] for p in points}) > 1 else []
    words += [f"{items} items"] if len({p[3] for p in points}) > 1 else []
    return ", ".join(words)


def slug(text: str) -> str:
    """`text` as a file name's part: letters, digits and underscores."""
    kept = "".join(c if c.isalnum() else "_" for c in text.lower())
    return "_".join(part for part in kept.split("_") if part)


def sweep_timeline_figures(rows: list[dict[str, str]], folder: str) -> dict[str, tuple[str, bytes]]:
    """{file name: (title in words, PNG)}: one figure per grid point of a sweep's timeline rows
    (`timeline_<point>.png`; `timeline.png` for a sweep of one point), then, with several
    points, their profits over time in one (`timeline_profit.png`)."""
    points = by_point(rows)
    out, timelines = {}, {}
    for point, seeds in points.items():
        name = point_name(point, list(points))
        timelines[name] = point_timeline(seeds)
        title = (
            f"{name}: picks per minute and profit over time, mean of {seeds_text(len(seeds))} "
            f"({folder})"
        )
        file = "timeline.png" if len(points) == 1 else f"timeline_{slug(name)}.png"
        out[file] = (title, point_png(timelines[name], title))
    if len(points) > 1:
        title = f"Profit over time of each grid point, mean over its seeds ({folder})"
        out["timeline_profit.png"] = (title, overlay_png(timelines, title))
    return out
