"""The line's coordination: what a free robot is offered, independent and coordinated."""

from __future__ import annotations

import pytest

from planner.decision import line_coordination
from planner.decision.interface import DecisionContext, TrackedItem
from planner.decision.line_coordination import (
    LineRobot,
    downstream_claims,
    offered_items,
    window_times,
)
from planner.errors import PlannerInputError
from planner.motion.reach_window import ReachWindow

V = 0.2  # belt speed [m/s]
PITCH = 1.5  # robots 1.5 m apart [m]


class _Cycle:
    def time_to_pick(self, start_xyz, item_xy, belt_speed):
        return 0.3

    def time_to_place(self, pick_xyz, bin_xyz):
        return 0.3


def _robots(n: int, free_at=None) -> list[LineRobot]:
    window = ReachWindow.disc(0.5)
    free_at = free_at or [0.0] * n
    return [
        LineRobot(DecisionContext(V, _Cycle(), window.shifted(k * PITCH)), free_at[k])
        for k in range(n)
    ]


def _item(i: int, x: float, y: float = 0.0) -> TrackedItem:
    return TrackedItem.certain(i, x, y, 2 + i % 3)


def test_a_shifted_window_and_the_window_times():
    robots = _robots(2)
    times = window_times(robots[1].context, 0.0, _item(0, 0.0))
    assert times == pytest.approx(((PITCH - 0.5) / V, (PITCH + 0.5) / V))
    assert window_times(robots[0].context, 0.0, _item(0, 0.0, y=0.6)) is None


def test_independent_offers_every_item():
    items = [_item(i, -0.3 * i) for i in range(5)]
    assert offered_items("independent", items, _robots(2), 0, 0.0, 0.7) == items


def test_a_free_robot_never_idles_while_items_pass_in_its_reach():
    # Two items far apart: the downstream robot, idle, could take both. Nothing would be lost,
    # so the upstream robot is offered what is in its reach now (it does not idle while the
    # item passes), and nothing that reaches it only later.
    items = [_item(0, -0.2), _item(1, -2.0)]
    robots = _robots(2)
    assert downstream_claims(items, robots, 0, 0.0, 0.7) == {0, 1}
    assert offered_items("coordinated", items, robots, 0, 0.0, 0.7) == [items[0]]
    assert offered_items("coordinated", [items[1]], robots, 0, 0.0, 0.7) == []


def test_robots_claim_and_are_offered_only_the_materials_they_sort():
    items = [_item(i, -0.2 - 0.05 * i) for i in range(6)]  # classes 2, 3, 4, 2, 3, 4
    window = ReachWindow.disc(0.5)
    only_alu = LineRobot(DecisionContext(V, _Cycle(), window.shifted(PITCH)), 0.0, frozenset({4}))
    robots = [_robots(1)[0], only_alu]
    claimed = downstream_claims(items, robots, 0, 0.0, 0.7)
    assert claimed and all(items[i].bin_class == 4 for i in claimed)
    # the last robot, sorting aluminium only, is offered aluminium only
    assert {it.bin_class for it in offered_items("independent", items, robots, 1, 0.0, 0.7)} == {4}
    with pytest.raises(PlannerInputError):
        LineRobot(robots[0].context, 0.0, frozenset())


def test_the_overflow_goes_upstream(monkeypatch):
    # Thirty items 21 mm apart on the centre line: item k enters the downstream robot's 1 m
    # window at 5 + 0.105 k s and leaves it 5 s later. Picking one every 0.75 s from 5 s in
    # order of deadline, skipping what it can no longer meet, it takes items 0..7 (5 + 0.75 k
    # <= 10 + 0.105 k), is free again at 11.0 s, then takes item 10 (leaving at 11.05 s), 17
    # (11.785 s) and 24 (12.52 s). The rest is what the upstream robot is offered.
    items = [_item(i, -0.021 * i) for i in range(30)]
    robots = _robots(2)
    # the bare list schedule (no slack on the cycle, no margin before the deadline)
    monkeypatch.setattr(line_coordination, "CLAIM_SLACK", 1.0)
    monkeypatch.setattr(line_coordination, "CLAIM_MARGIN_S", 0.0)
    claimed = downstream_claims(items, robots, 0, 0.0, 0.75)
    assert claimed == {*range(8), 10, 17, 24}
    offered = offered_items("coordinated", items, robots, 0, 0.0, 0.75)
    # offered: the unclaimed items in robot 0's window (x >= -0.5 m) within START_HORIZON_S
    # (0.3 s: 6 cm more at 0.2 m/s), i.e. items 0..26
    soon = [i for i in range(30) if -0.021 * i >= -0.5 - V * line_coordination.START_HORIZON_S]
    assert soon == list(range(27))
    assert [it.item_id for it in offered] == [i for i in soon if i not in claimed]
    # the last robot is offered everything in its reach soon: nobody downstream to leave to
    assert offered_items("coordinated", items, robots, 1, 0.0, 0.75) == []  # 5 s away
    # 4.96 s on, item k is 0.04 + 0.105 k s from the downstream window: items 0..2 are soon
    later = [_item(it.item_id, it.x + 0.992) for it in items]
    assert offered_items("coordinated", later, robots, 1, 4.96, 0.75) == later[:3]
    # with the slack and the margin the downstream robot claims fewer: more goes upstream
    monkeypatch.undo()
    cautious = downstream_claims(items, robots, 0, 0.0, 0.75)
    assert len(cautious) < len(claimed) and {0, 1, 2, 3, 4} <= cautious


def test_a_busy_downstream_robot_claims_less():
    items = [_item(i, -0.25 * i) for i in range(8)]
    idle = downstream_claims(items, _robots(2), 0, 0.0, 0.7)
    busy = downstream_claims(items, _robots(2, free_at=[0.0, 12.0]), 0, 0.0, 0.7)
    assert len(busy) < len(idle)


def test_bad_input_is_refused():
    with pytest.raises(PlannerInputError):
        offered_items("greedy", [], _robots(2), 0, 0.0, 0.7)
    with pytest.raises(PlannerInputError):
        offered_items("coordinated", [], _robots(2), 2, 0.0, 0.7)
    with pytest.raises(PlannerInputError):
        downstream_claims([], _robots(2), 0, 0.0, 0.0)
