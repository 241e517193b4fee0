"""The faults' state in one episode: the one owner of what the schedule has failed now.

`CellFaults` is a scheduled event (`sim.episode.scheduler`) due at every start and end of a
fault, registered only when the schedule has any (a run without faults steps as it always
did). At a start it fails the part, at an end it brings it back, each as the real cell does:

- robot_stop: a protective stop. The robot's motors hold their last set-points, its cup keeps
  what it holds, it makes no decision and the line's coordination counts it busy until the
  stop ends (`sim.episode.stations.line_offer`). After the stop the pick goes on when the cup
  holds its item (carried to its bin); a pick that had not sealed is given up where the robot
  stands, its item offered again (this robot, deciding at once, takes it again if it can still
  meet it; another robot may), and the robot decides from there.
- camera_outage: the camera gives no frames (`blind_cameras`, read by the observations).
- vacuum_drop: every cup's supply falls to the fault's vacuum (`sim.cell.suction`).
- belt_stop, belt_speed: the belt runs at 0 or the fault's factor of its speed, the infeed with
  it (its drops shift: `sim.episode.infeed.Infeed.run_at`); the tracks move on at the new
  speed from where the old one carried them, and every plan made from then on (the decision
  managers' contexts, the pick controllers' intercepts) sees the belt as it runs now. A pick
  under way goes on as planned, as a controller without conveyor tracking plays a chain it
  has started: its cup may come down where its item is no more, then lifts empty, and the item
  is offered again while it is in reach (truth perception reports it again; the camera's track
  of it, which the camera will not renew, is given back where the belt carried it:
  `sim.episode.stations.book_pick`).

The timeline reads `robot_state(k, t)` and `active(t)`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from sim.config.faults import Fault, FaultSchedule
from sim.episode.parts import is_due

if TYPE_CHECKING:
    from sim.episode.parts import EpisodeParts
    from sim.episode.stations import RobotStation

BELT_KINDS = ("belt_stop", "belt_speed")
"""The faults that change the belt's speed."""
ROBOT_STATES = ("picking", "idle", "stopped")
"""What a robot is doing, as the timeline reports it."""


class CellFaults:
    """What the schedule has failed now, and the event acting at each fault's start and end.

    Args:
        schedule: The episode's faults.
        stations: The robots' stations, upstream first.
        cameras: How many cameras the cell has (a fault on every camera fails each).
    """

    def __init__(self, schedule: FaultSchedule, stations: tuple[RobotStation, ...], cameras: int):
        self.schedule, self.stations, self.cameras = schedule, stations, int(cameras)
        self._times = schedule.boundaries()
        self._next = 0  # index of the next boundary in `_times`
        self._started: set[int] = set()
        self._ended: set[int] = set()
        self.blind_cameras: frozenset[int] = frozenset()
        """The cameras giving no frames now."""

    # ----- what is read ---------------------------------------------------------------------

    def active(self, t: float) -> tuple[Fault, ...]:
        """The faults holding at sim time `t` [s]."""
        return self.schedule.active(t)

    def robot_state(self, k: int, t: float) -> str:
        """Robot `k`'s state at sim time `t` [s]: "stopped", "picking" or "idle"."""
        if any(f.robot == k for f in self.schedule.active(t) if f.kind == "robot_stop"):
            return "stopped"
        return "picking" if self.stations[k].robot.busy else "idle"

    # ----- the event ------------------------------------------------------------------------

    def due(self, t: float) -> bool:
        return self._next < len(self._times) and is_due(t, self._times[self._next])

    def next_time(self, t: float) -> float | None:
        return self._times[self._next] if self._next < len(self._times) else None

    def fire(self, parts: EpisodeParts) -> None:
        """End the faults due to end, then start those due to start; then the belt's speed."""
        t = float(parts.data.time)
        while self._next < len(self._times) and is_due(t, self._times[self._next]):
            self._next += 1
        faults, belt = self.schedule.faults, False
        for i, fault in enumerate(faults):
            if i in self._started and i not in self._ended and is_due(t, fault.end_s):
                self._ended.add(i)
                self._end(fault, parts, t)
                belt |= fault.kind in BELT_KINDS
        for i, fault in enumerate(faults):
            if i not in self._started and is_due(t, fault.start_s):
                self._started.add(i)
                self._start(fault, parts, t)
                belt |= fault.kind in BELT_KINDS
        if belt:
            self._run_belt(parts, t)

    def belt_factor(self) -> float:
        """The belt's speed now as a factor of its set speed (0: stopped)."""
        running = [
            f
            for i, f in enumerate(self.schedule.faults)
            if f.kind in BELT_KINDS and i in self._started and i not in self._ended
        ]
        if any(f.kind == "belt_stop" for f in running):
            return 0.0
        factor = 1.0
        for f in running:
            assert f.speed_factor is not None
            factor *= f.speed_factor
        return factor

    def _run_belt(self, parts: EpisodeParts, t: float) -> None:
        """The belt, the infeed, the tracks and every plan from now on at the belt's speed
        now (the riders carried up to now at the old one: the items are brought up to date
        before any event fires)."""
        factor = self.belt_factor()
        set_speed = parts.config.belt_speed_mps
        speed = set_speed if factor == 1.0 else set_speed * factor
        parts.cell.pool.belt.run_at(speed, t)
        parts.infeed.run_at(t, factor)
        parts.tracker.rebase(t, speed)
        parts.offers.belt_speed = speed
        for station in self.stations:
            station.robot.belt_speed = speed
            station.context = replace(station.context, belt_speed=speed)

    def _start(self, fault: Fault, parts: EpisodeParts, t: float) -> None:
        if fault.kind == "robot_stop":
            assert fault.robot is not None
            station = self.stations[fault.robot]
            station.stop_until(fault.end_s)
            station.robot.halt()
        elif fault.kind == "camera_outage":
            self.blind_cameras |= self._cameras_of(fault)
        elif fault.kind == "vacuum_drop":
            assert fault.vacuum_pa is not None
            for station in self.stations:
                station.robot.suction.supply(fault.vacuum_pa)

    def _end(self, fault: Fault, parts: EpisodeParts, t: float) -> None:
        if fault.kind == "robot_stop":
            assert fault.robot is not None
            self._restart(self.stations[fault.robot], parts, t)
        elif fault.kind == "camera_outage":
            self.blind_cameras -= self._cameras_of(fault)
        elif fault.kind == "vacuum_drop":
            for station in self.stations:
                station.robot.suction.supply(None)

    def _cameras_of(self, fault: Fault) -> frozenset[int]:
        return frozenset(range(self.cameras) if fault.camera is None else (fault.camera,))

    @staticmethod
    def _restart(station: RobotStation, parts: EpisodeParts, t: float) -> None:
        """After a protective stop: the pick goes on if the cup holds its item, else it is
        given up where the robot stands and its item offered again; an idle robot decides."""
        pick = station.pick
        if station.robot.resume(t) or pick is None:
            if pick is None:
                station.decide_at(t)
            return
        station.pick, station.path = None, None
        tracker = parts.tracker
        track = pick.track
        if track.true_id is None or not any(tr.true_id == track.true_id for tr in tracker.tracks()):
            tracker.restore(track)
        station.decide_at(t)
