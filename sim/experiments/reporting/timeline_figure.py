"""A run's timeline as a figure (`sim.results.timeline`): picks per minute and profit over
time, the faults active as shaded bands. A sweep's timeline (its rows keyed by episode) is drawn
per grid point over its seeds (`sim.experiments.reporting.sweep_timeline`).

The picks per minute of a row are the picks since the row before over the minutes between
them; a fault's band covers the rows during which the timeline saw it active (the faults column,
sampled every `[timeline] period_s`: a band is as fine as the period).
"""

from __future__ import annotations

import io
from pathlib import Path

from sim.config.faults import FAULT_KINDS
from sim.experiments.reporting.fault_colours import BAND_COLOURS
from sim.results.timeline import TIMELINE_FILE, read_timeline


def series(rows: list[dict[str, str]]) -> tuple[list[float], list[float], list[float]]:
    """(minutes, picks per minute, profit [EUR]) of the rows, from t = 0 (nothing picked)."""
    minutes, rates, profit = [0.0], [0.0], [0.0]
    picked = 0
    for row in rows:
        t = float(row["t_s"]) / 60.0
        n = int(row["picked"])
        span = t - minutes[-1]
        rates.append((n - picked) / span if span > 0 else rates[-1])
        minutes.append(t)
        profit.append(float(row["profit_eur"]))
        picked = n
    return minutes, rates, profit


def bands(rows: list[dict[str, str]]) -> list[tuple[str, float, float]]:
    """(fault kind, start [min], end [min]) of each run of rows that saw a fault of that kind
    active: from the row before to the last such row."""
    out: list[tuple[str, float, float]] = []
    open_at: dict[str, float] = {}
    before = 0.0
    for row in rows:
        t = float(row["t_s"]) / 60.0
        kinds = {label.split(" ")[0] for label in row["faults"].split("; ") if label}
        for kind in FAULT_KINDS:
            if kind in kinds and kind not in open_at:
                open_at[kind] = before
            elif kind not in kinds and kind in open_at:
                out.append((kind, open_at.pop(kind), before))
        before = t
    out += [(kind, start, before) for kind, start in open_at.items()]
    return out


def timeline_png(rows: list[dict[str, str]], title: str) -> bytes:
    """The figure's PNG: picks per minute above, profit below, the fault bands on both."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    minutes, rates, profit = series(rows)
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(6.4, 4.8), dpi=100)
    top.step(minutes, rates, where="pre", color="tab:blue")
    top.set_ylabel("picks per minute")
    top.set_title(title)
    bottom.plot(minutes, profit, color="tab:green")
    bottom.set_ylabel("profit so far [EUR]")
    bottom.set_xlabel("simulated time [min]")
    seen: set[str] = set()
    for kind, start, end in bands(rows):
        for ax in (top, bottom):
            label = kind if ax is top and kind not in seen else None
            ax.axvspan(start, end, color=BAND_COLOURS[kind], alpha=0.25, label=label)
        seen.add(kind)
    if seen:
        top.legend(fontsize=7, loc="upper right")
    for ax in (top, bottom):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    plt.close(fig)
    return buffer.getvalue()


def timeline_figures(folders: list[Path]) -> dict[str, tuple[str, bytes]]:
    """{file name: (title in words, PNG)} of each folder's timeline.csv: a run's figure, or a
    sweep's, one per grid point (`sweep_timeline`); a folder without one adds nothing. With
    several folders each file name starts with its folder's (`timeline_<folder>...png`)."""
    from sim.experiments.reporting.sweep_timeline import is_sweep_timeline, sweep_timeline_figures

    out = {}
    for folder in folders:
        rows = read_timeline(Path(folder) / TIMELINE_FILE)
        if not rows:
            continue
        where = Path(folder).name
        if is_sweep_timeline(rows):
            figures = sweep_timeline_figures(rows, where)
        else:
            title = f"Picks per minute and profit over time, faults shaded ({where})"
            figures = {"timeline.png": (title, timeline_png(rows, title))}
        for name, figure in figures.items():
            own = name if len(folders) == 1 else name.replace("timeline", f"timeline_{where}", 1)
            out[own] = figure
    return out
