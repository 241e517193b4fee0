"""An episode over time: `timeline.csv`, one row every `[timeline] period_s` of simulated time.

Each row holds the counts so far (entered, picked, missed, wrong bin, dropped), the profit so
far, the items in play (on the belt or in a cup, not yet booked; the last row, at the end, also
those left on the belt at the horizon), each robot's state (picking | idle | stopped) and the
faults active then (their labels, `sim.config.faults.Fault.label`, joined by "; "). The counts
add up in every row: entered = picked + missed + dropped + on_belt.

Rows are streamed to disk as they are made (`TimelineWriter`, as picks.csv's rows are): a run
stopped by Ctrl-C leaves the rows made so far in `timeline.interrupted.csv`; a run that
finishes writes `timeline.csv` with its other files (one unit,
`sim.results.outputs.write_together`); a disk that fills keeps them in memory, and with the
run's other results elsewhere.

A sweep keeps each episode's rows in memory and appends them, each led by its episode's key
columns, to the sweep's own timeline.csv as the episode finishes
(`sim.experiments.sweep_runner`, `append_rows`).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from sim.config.faults import FAULT_KINDS, FaultSchedule, availability

TIMELINE_FILE = "timeline.csv"
INTERRUPTED_FILE = "timeline.interrupted.csv"
"""Where a stopped `sortsim run` leaves the timeline's rows so far."""
ROBOT_STATES = ("picking", "idle", "stopped")
COUNT_COLUMNS = ("entered", "picked", "missed", "wrong_bin", "dropped")
DECIMALS = {"t_s": 3, "profit_eur": 4}


def timeline_columns(robots: int) -> tuple[str, ...]:
    """The columns of a cell's or line's timeline with `robots` robots."""
    states = tuple(f"robot_{k}_state" for k in range(robots))
    return ("t_s", *COUNT_COLUMNS, "profit_eur", "on_belt", *states, "faults")


def timeline_row(
    t_s: float, metrics: Any, on_belt: int, states: Sequence[str], faults: Iterable[Any]
) -> dict[str, Any]:
    """One row at sim time `t_s` [s].

    Args:
        t_s: When it was sampled [s].
        metrics: The episode's counters (`sim.results.metrics.EpisodeMetrics`).
        on_belt: Items in play then.
        states: Each robot's state, upstream first (one of `ROBOT_STATES`).
        faults: The faults active then (`sim.config.faults.Fault`).
    """
    row = metrics.row()
    counts = {c: row[c] for c in COUNT_COLUMNS}
    robots = {f"robot_{k}_state": s for k, s in enumerate(states)}
    labels = "; ".join(f.label() for f in faults)
    return {"t_s": t_s, **counts, "profit_eur": row["profit_eur"], "on_belt": on_belt} | (
        robots | {"faults": labels}
    )


def robot_state(busy: bool, k: int, t: float, schedule: FaultSchedule | None) -> str:
    """Robot `k`'s state at `t` [s]: stopped while a robot_stop fault of it is active, else
    picking while it plays a pick, else idle."""
    if schedule is not None and any(
        f.kind == "robot_stop" and f.robot == k for f in schedule.active(t)
    ):
        return "stopped"
    return "picking" if busy else "idle"


def format_cell(column: str, value: Any) -> str:
    """A cell's text: fixed decimals for the time and the profit."""
    if column in DECIMALS:
        return f"{float(value):.{DECIMALS[column]}f}"
    return str(value)


class TimelineWriter:
    """Rows streamed to the disk as they are made (`sim.results.outputs.PickStream`: a hidden
    temporary beside timeline.csv, whole rows only, in memory once the disk fills); only the
    last row is kept (`last`), so a shift's timeline takes no memory as it grows. `kept` is
    empty. `finish()` hands the rows to `write_together`; `land(path)` renames the rows so far
    on their own (a stopped run's `INTERRUPTED_FILE`); `close()` removes a temporary that did
    not land.

    Args:
        path: The timeline.csv it stands for.
        columns: Its columns.
    """

    def __init__(self, path: Path | str, columns: Sequence[str]):
        from sim.results.outputs import PickStream

        self.path, self.columns = Path(path), tuple(columns)
        self.last: dict[str, Any] | None = None
        self.kept: list[dict[str, Any]] = []
        self._stream = PickStream(self.path, self.columns).__enter__()

    def __call__(self, row: dict[str, Any]) -> None:
        """Write `row` (its cells as `format_cell` writes them) whole."""
        self.last = row
        self._stream.write_row({c: format_cell(c, row.get(c, "")) for c in self.columns})

    def text(self) -> str:
        """The CSV text of the rows so far."""
        return self._stream.text()

    def finish(self) -> Path | str:
        """The rows, ready for `write_together`: the synced temporary, or their text."""
        return self._stream.finish()

    def land(self, path: Path | str) -> Path:
        """Rename the rows so far into `path` on their own."""
        return self._stream.land(path)

    def close(self) -> None:
        self._stream.__exit__(None, None, None)


class RowList:
    """Rows kept in memory only (a sweep's episode, a test): the writer's interface, every row
    in `kept`."""

    def __init__(self, columns: Sequence[str]):
        self.columns = tuple(columns)
        self.kept: list[dict[str, Any]] = []

    @property
    def last(self) -> dict[str, Any] | None:
        return self.kept[-1] if self.kept else None

    def __call__(self, row: dict[str, Any]) -> None:
        self.kept.append(row)

    def close(self) -> None:
        pass


def to_text(columns: Sequence[str], rows: Iterable[dict[str, Any]]) -> str:
    """The whole CSV text of `rows`, as `TimelineWriter` writes them."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([format_cell(c, row.get(c, "")) for c in columns])
    return buffer.getvalue()


def write_rows(path: Path | str, columns: Sequence[str], rows: Iterable[dict[str, Any]]) -> Path:
    """Write a timeline file of `rows` whole, through a temporary and a rename (a sweep's
    timeline.csv: each row's episode key cells given as text)."""
    from sim.results.outputs import write_atomic

    return write_atomic(Path(path), to_text(columns, rows))


def append_rows(path: Path | str, columns: Sequence[str], rows: Iterable[dict[str, Any]]) -> Path:
    """Add `rows` at the end of the timeline file `path` (rewritten whole, as `write_rows`; the
    rows already there are kept as text: `format_cell` of a cell's text is that text)."""
    from sim.results.outputs import read_rows

    return write_rows(path, columns, [*read_rows(Path(path)), *rows])


def downtime_columns() -> tuple[str, ...]:
    """episodes.csv's fault columns: `downtime_<kind>_s` per kind, then `availability`."""
    return (*(f"downtime_{k}_s" for k in FAULT_KINDS), "availability")


def downtime_row(schedule: FaultSchedule | None, robots: int, end_s: float) -> dict[str, float]:
    """Seconds of each kind of fault before `end_s` [s] and the robots' availability [0, 1]
    (`sim.config.faults.availability`); no schedule: no downtime, availability 1."""
    schedule = schedule or FaultSchedule()
    row = {f"downtime_{k}_s": schedule.downtime_s(k, end_s) for k in FAULT_KINDS}
    return row | {"availability": availability(schedule, robots, end_s)}


def read_timeline(path: Path | str) -> list[dict[str, str]]:
    """The rows of a timeline.csv (empty when there is none)."""
    path = Path(path)
    if not path.exists():
        return []
    with path.open(newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))
