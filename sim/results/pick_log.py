"""An episode's pick attempts: their totals, and their picks.csv rows kept or streamed in order.

picks.csv lists the attempts in the order they started (by start time, then item id), while
they are booked when they end: on a line, a robot's long pick ends after a neighbour's later,
shorter one. `PickLog` keeps the totals episodes.csv needs (summed in booking order, so they are
the same floats as sums over the whole list) and either keeps every record (`pick_rows` sorts
them) or hands rows to a sink as soon as no attempt still under way can start before them: a
small heap holds the finished attempts that started after the earliest one under way, so memory
stays flat over a shift while the rows come out in picks.csv's order.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field
from typing import Any, Protocol

from perception.codes import THESIS_MATERIALS, Materials


@dataclass(frozen=True)
class PickRecord:
    """One pick attempt (a row of picks.csv); times [s], travel [m], energy [J]."""

    t_start_s: float
    t_end_s: float
    item_id: int
    true_class: int | None
    predicted_class: int
    bin: int | None
    success: bool
    travel_m: float = 0.0
    energy_mech_j: float = 0.0
    energy_elec_j: float = 0.0
    sealed: bool = True  # False: the cup never sealed, it carried no item (not in picks.csv)
    robot: int = 0  # the robot of a line that made the attempt (0 upstream)

    def row(self, materials: Materials = THESIS_MATERIALS) -> dict[str, Any]:
        """The picks.csv row of this attempt (class names those of `materials`)."""
        return {
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "item_id": self.item_id,
            "true_class": materials.name_of(self.true_class),
            "predicted_class": materials.name_of(self.predicted_class),
            "bin": materials.name_of(self.bin),
            "success": self.success,
            "cycle_s": self.t_end_s - self.t_start_s,
            "travel_m": self.travel_m,
            "energy_mech_j": self.energy_mech_j,
            "energy_elec_j": self.energy_elec_j,
            "robot": self.robot,
        }

    @property
    def order(self) -> tuple[float, int]:
        """Its place in picks.csv: start time, then item id."""
        return (self.t_start_s, self.item_id)


class RowSink(Protocol):
    """Where streamed rows go (`sim.results.outputs.PickStream`)."""

    def write_row(self, row: dict[str, Any]) -> None: ...


@dataclass
class RobotTotals:
    """One robot's finished attempts: those that binned their item, and their summed
    duration from start to release [s]."""

    binned: int = 0
    busy_s: float = 0.0


@dataclass
class PickLog:
    """The attempts of one episode (`EpisodeMetrics.picks` when kept).

    Args:
        materials: The cell's materials (the rows' class names).
    """

    materials: Materials = THESIS_MATERIALS
    attempts: int = 0
    failed: int = 0
    empty: int = 0  # the cup never sealed
    sealed_failures: int = 0  # never sealed yet counted a success: an accounting failure
    success_cycles: int = 0
    success_cycle_s: float = 0.0  # summed cycle time of the successful attempts [s]
    robots: dict[int, RobotTotals] = field(default_factory=dict)
    kept: list[PickRecord] | None = field(default_factory=list)
    _sink: RowSink | None = None
    _pending: list[tuple[tuple[float, int], int, PickRecord]] = field(default_factory=list)
    _under_way: dict[int, float] = field(default_factory=dict)

    def stream_to(self, sink: RowSink) -> None:
        """From now on hand each row to `sink` in picks.csv's order instead of keeping it."""
        self._sink, self.kept = sink, None

    def started(self, robot: int, t_start_s: float) -> None:
        """Robot `robot` started an attempt at `t_start_s` [s] (rows after it wait for it)."""
        self._under_way[int(robot)] = float(t_start_s)

    def add(self, record: PickRecord) -> None:
        """An attempt ended: counted, then kept or (once in order) streamed."""
        self.attempts += 1
        self.failed += not record.success
        self.empty += not record.sealed
        self.sealed_failures += record.success and not record.sealed
        totals = self.robots.setdefault(record.robot, RobotTotals())
        cycle = record.t_end_s - record.t_start_s
        totals.busy_s += cycle
        if record.success:
            totals.binned += 1
            self.success_cycles += 1
            self.success_cycle_s += cycle
        if self.kept is not None:
            self.kept.append(record)
            return
        self._under_way.pop(record.robot, None)
        heapq.heappush(self._pending, (record.order, self.attempts, record))
        self._release(min(self._under_way.values(), default=math.inf))

    def finish(self) -> None:
        """The episode ended (or stopped): every row still held goes to the sink."""
        self._under_way.clear()
        self._release(math.inf)

    def _release(self, before_s: float) -> None:
        """Hand the sink the held rows that started before `before_s` [s], in order."""
        if self._sink is None:
            return
        while self._pending and self._pending[0][0][0] < before_s:
            record = heapq.heappop(self._pending)[2]
            self._sink.write_row(record.row(self.materials))

    def rows(self) -> list[dict[str, Any]]:
        """The kept attempts' picks.csv rows, in the order they started (none when streamed)."""
        records = sorted(self.kept or (), key=lambda p: (p.t_start_s, p.item_id))
        return [p.row(self.materials) for p in records]
