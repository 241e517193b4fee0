"""The robots of an episode: each robot's station (pick controller, energy meter, decision
context and manager, the pick under way), what the line offers the decision managers
(`Offers`) and how a line's coordination shares it out.

A cell has one robot, a line up to four; the one loop steps them all (`sim.episode.loop`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from planner.decision.interface import Choice, DecisionContext, TrackedItem
from planner.decision.line_coordination import LineRobot, offered_items
from planner.decision.robot_materials import covering_stopped
from sim.cell.riding import PlannedPath
from sim.cell.suction import SuctionEvent
from sim.episode.pick_control import PickController, PickOutcome
from sim.flow.generator import Flow
from sim.monitors.energy import EnergyMeter
from sim.results.metrics import EpisodeMetrics, PickRecord
from sim.sensing.confidence import sure_items
from sim.sensing.tracking import Track, Tracker

MAX_FAILURES = 2
"""Attempts after which truth mode gives an item up (it is re-detected every period)."""
LINE_PICK_TIME_S = 0.75
"""A pick's duration a line's coordination assumes before a robot has picked [s] (the
headline episode's mean cycle is 0.73 s)."""


@dataclass(frozen=True)
class PickUnderWay:
    """A pick under way, as it started (the pick controller keeps its plan,
    `sim.episode.pick_control.StartedPick`).

    Attributes:
        track: The track picked.
        choice: The decision manager's choice.
        energy_at_start: The robot's (mechanical, electrical) energy readings then [J].
        travel_m: The thesis's distance of the pick: rest -> item -> bin in the belt's
            plane [m].
        t_start_s: When it started [s].
    """

    track: Track
    choice: Choice
    energy_at_start: tuple[float, float]
    travel_m: float
    t_start_s: float


class RobotStation:
    """One robot of an episode.

    Args:
        index: The robot's index, 0 upstream.
        robot: Its pick controller.
        energy: Its motors' energy meter.
        context: Its decision context (its window, its bins).
        planner: Its decision manager.
        path_reach: (around, below) how far the cup, or an item hanging from it, reaches from
            the cup's centre [m] (riders its planned path passes are woken as a pick starts).
    """

    def __init__(
        self,
        index: int,
        robot: PickController,
        energy: EnergyMeter,
        context: DecisionContext,
        planner,
        path_reach: tuple[float, float],
    ):
        self.index, self.robot, self.energy = index, robot, energy
        self.context, self.planner, self.path_reach = context, planner, path_reach
        self.next_decision = 0.0
        """When the robot, idle, asks its decision manager next [s]."""
        self.pick: PickUnderWay | None = None
        """The pick under way (None: idle)."""
        self.path: PlannedPath | None = None
        """The cup's planned path of the pick under way (riders it passes are woken)."""
        self.picks_done, self.pick_time_sum = 0, 0.0  # its finished picks and their time [s]
        self.stopped_until = 0.0
        """When its last protective stop ends [s] (`sim.episode.faults`): no decision before."""

    def start(self, pick: PickUnderWay, path: PlannedPath | None) -> None:
        """The pick `pick` is under way along `path` (None: riders are not woken by it)."""
        self.pick, self.path = pick, path

    def stop_until(self, t: float) -> None:
        """A protective stop holds the robot until sim time `t` [s]: it decides then, not before
        (a pick under way is held by its controller, `PickController.halt`)."""
        self.stopped_until = t
        if self.pick is None:
            self.next_decision = t

    def decide_at(self, t: float) -> None:
        """Ask the decision manager next at sim time `t` [s]."""
        self.next_decision = t

    def new_cup_events(self) -> list[SuctionEvent]:
        """The cup's events since this was last asked."""
        return self.robot.suction.take_events()

    @property
    def current_pick(self) -> Track | None:
        """The track being picked (None when idle; shown in the video)."""
        return self.pick.track if self.pick is not None else None

    @property
    def mean_pick_s(self) -> float:
        """Mean duration of the robot's picks so far [s] (`LINE_PICK_TIME_S` before any)."""
        if not self.picks_done:
            return LINE_PICK_TIME_S
        return self.pick_time_sum / self.picks_done


def line_offer(
    stations: Sequence[RobotStation],
    station: RobotStation,
    items: list[TrackedItem],
    t: float,
    coordination: str,
    robot_class_ids: tuple,
) -> list[TrackedItem]:
    """The items a free robot of a line may choose among (`coordination`,
    `planner.decision.line_coordination`); all of them for one robot. A robot's pick is taken
    to last its mean pick so far.

    Args:
        stations: Every robot's station, upstream first.
        station: The robot choosing.
        items: The tracked items.
        t: Sim time now [s].
        coordination: "independent" or "coordinated".
        robot_class_ids: Per robot, the material class ids it sorts (None: every material);
            while a robot is stopped the others take its materials too
            (`planner.decision.robot_materials.covering_stopped`).
    """
    if len(stations) <= 1 or not items:
        return items
    stopped = [s.index for s in stations if s.stopped_until > t]
    classes = covering_stopped(robot_class_ids, stopped)  # a stopped robot's items re-offered
    line = []
    for s in stations:
        if s.robot.busy:
            assert s.pick is not None  # a busy robot's station holds its pick
            free_at = s.pick.t_start_s + s.mean_pick_s
        else:
            free_at = t
        free_at = max(free_at, s.stopped_until)  # a stopped robot is free once restarted
        line.append(LineRobot(s.context, max(free_at, t), classes[s.index]))
    return offered_items(coordination, items, line, station.index, t, station.mean_pick_s)


def book_pick(
    station: RobotStation,
    outcome: PickOutcome,
    flow: Flow,
    offers: Offers,
    metrics: EpisodeMetrics,
) -> None:
    """Book a robot's finished pick in `metrics`; an item the cup failed on counts a failure in
    `offers` (truth mode gives it up after `MAX_FAILURES`), the item sealed is tracked no more.
    """
    pick = station.pick
    assert pick is not None, "book_pick needs the station's pick under way"
    track, choice, (mech0, elec0) = pick.track, pick.choice, pick.energy_at_start
    station.pick = None
    station.picks_done += 1
    station.pick_time_sum += outcome.t_end - outcome.t_start
    mech, elec = station.energy.reading()
    if not outcome.held_to_bin and track.true_id is not None:
        offers.failed(track.true_id)
    tracker = offers.tracker
    if not outcome.sealed and track.true_id is None and tracker.speed_changed_since(pick.t_start_s):
        # The belt stopped or changed speed during the pick: the chain met the item where the
        # old speed would have carried it, and the cup came down beside it. The camera saw the
        # item once and will not again: its track is given back where the belt carried it.
        tracker.restore(track)
    if outcome.item_id >= 0:  # the cup may have sealed on a neighbour: forget its track too
        offers.tracker.remove_true(outcome.item_id)
    true_class = int(flow.class_id[outcome.item_id]) if outcome.item_id >= 0 else None
    if true_class is None and track.true_id is not None:
        true_class = int(flow.class_id[track.true_id])
    metrics.on_pick(
        PickRecord(
            t_start_s=outcome.t_start,
            t_end_s=outcome.t_end,
            item_id=outcome.item_id if outcome.item_id >= 0 else (track.true_id or -1),
            true_class=true_class,
            predicted_class=track.predicted_class,
            bin=choice.bin_class,
            success=outcome.held_to_bin,
            travel_m=pick.travel_m,
            energy_mech_j=mech - mech0,
            energy_elec_j=elec - elec0,
            sealed=outcome.sealed,
            robot=station.index,
        )
    )


class Offers:
    """What the decision managers are offered: the tracked items not given up, not waiting for
    a retry and sure enough (the confidence rule, `sim.sensing.confidence`); owns the failed
    attempts per true item, when each track may be offered again and the item each track was
    offered as last.

    Args:
        tracker: The episode's tracker.
        belt_speed: The belt's speed [m/s].
        min_confidence: The confidence rule's threshold in [0, 1].
    """

    def __init__(self, tracker: Tracker, belt_speed: float, min_confidence: float):
        self.tracker, self.belt_speed, self.min_confidence = tracker, belt_speed, min_confidence
        self.failures: dict[int, int] = {}  # failed attempts per true item id (truth mode)
        self.not_before: dict[int, float] = {}  # track id -> when it may be offered again [s]
        # track id -> (its probabilities, its item) as `items` last made them
        self.track_items: dict[int, tuple[np.ndarray, TrackedItem]] = {}

    def failed(self, true_id: int) -> None:
        """The cup failed on true item `true_id` once more."""
        self.failures[true_id] = self.failures.get(true_id, 0) + 1

    def retry_after(self, track_id: int, t: float) -> None:
        """Track `track_id` is not offered before sim time `t` [s]."""
        self.not_before[track_id] = t

    def items(self, t: float) -> list[TrackedItem]:
        """The items offered at sim time `t` [s], once for all robots."""
        items, made = [], {}
        for tr in self.tracker.tracks():
            if tr.true_id is not None and self.failures.get(tr.true_id, 0) >= MAX_FAILURES:
                continue  # truth mode: an item the cup failed on twice is given up
            if self.not_before.get(tr.track_id, 0.0) > t:
                continue  # the cup could not meet it a moment ago
            x = tr.x_at(t, self.belt_speed)
            # The track's item of the last call, moved, while its probabilities are the same
            # array (the tracker replaces the array when it updates them).
            probs, item = self.track_items.get(tr.track_id, (None, None))
            if probs is tr.probs:
                assert item is not None  # stored with its probabilities
                item = item.at(x, tr.y)
            else:
                item = TrackedItem(tr.track_id, x, tr.y, tuple(tr.probs))
            made[tr.track_id] = (tr.probs, item)
            items.append(item)
        self.track_items = made
        return sure_items(items, self.min_confidence)
