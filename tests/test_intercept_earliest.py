"""The intercept meets an item at the earliest time the robot can, not merely at a feasible one.

The earliest feasible meeting is found here independently of `intercept_item`'s fixed-point
iteration: candidate meeting times T are scanned on a fine grid with the same feasibility test
(the contact, approach, seal-end and lift points reachable where the belt has carried the item
by T; the time-optimal pick half to that point touching down no later than T), and the first
feasible one is compared with the answer. An item still upstream of the window is met where it
enters, which the intercept finds on its `SCAN_DT` (20 ms) grid. Items near the window's
downstream edge are either met at the earliest feasible time or refused, and a refusal is
checked against the same scan: no time up to the item's exit is feasible.

How late is allowed: `TIME_TOL` documents that the cup waits at most 1 ms above the item, and
most meetings are within it. When the pick gets shorter as the item rides towards the robot's
start, the iteration's first step from the window's entry overshoots the earliest meeting and
is kept: about 1 item in 15 is met 6-8 ms late. The general bound here is `LATE_TOL` (10 ms);
`test_documented_one_ms_slack_when_the_item_rides_towards_the_robot` pins the documented 1 ms
on such an item and is expected to fail until the iteration refines its overshoot.
"""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import PlannerInputError
from planner.motion import intercept as intercept_module
from planner.motion.intercept import intercept_item
from planner.motion.kinematics import reachable_mask
from planner.motion.limits import limits_for_payload
from planner.motion.pick_cycle import PickPlaceConfig, pick_place_waypoints, plan_pick
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from planner.motion.trajectory import State
from sim.cell.executor import lumped_dynamics
from sim.cell.robot import geometry_from_model
from sim.model.mjcf import load_robot

SPEEDS = (0.185, 0.222, 0.2775)
PICK_Z = 0.02
BINS = ((0.0, -0.51, 0.06), (-0.21, 0.51, 0.06), (0.21, 0.51, 0.06))
CONFIG = PickPlaceConfig()
COARSE = 0.005  # [s] first scan of candidate meeting times
FINE = 0.0005  # [s] refinement inside the coarse step where feasibility begins
LATE_TOL = 0.010  # [s] latest meeting allowed after the earliest feasible one (see above)
DOC_TOL = intercept_module.TIME_TOL + 2 * FINE  # [s] the documented slack + grid
UPSTREAM_TOL = intercept_module.SCAN_DT + 2 * FINE  # [s] window entry found on a 20 ms grid


@pytest.fixture(scope="module")
def robot():
    """(geometry, generator) of the robot alone, planned for a 0.1 kg payload."""
    model = load_robot()
    geom = geometry_from_model(model)
    gen = RuckigTrajectoryGenerator(limits_for_payload(0.1), geom, lumped_dynamics(model, geom))
    return geom, gen


def in_window(geom, x: float, y: float, speed: float) -> bool:
    """Contact, approach, seal-end and lift points all reachable for a meeting at (x, y)."""
    seal_x = x + speed * CONFIG.seal_time
    pts = np.array(
        [
            (x, y, PICK_Z),
            (x, y, PICK_Z + CONFIG.approach_height),
            (seal_x, y, PICK_Z),
            (seal_x, y, PICK_Z + CONFIG.lift_height),
        ]
    )
    return bool(np.all(reachable_mask(geom, pts)))


def feasible(robot, start: State, item, speed: float, t: float, drop) -> bool:
    """Whether the cup can meet the item at time `t` [s]: the item is inside the window then
    and the time-optimal pick half to where it will be touches down by `t`."""
    geom, gen = robot
    x, y = item[0] + speed * t, item[1]
    if not in_window(geom, x, y, speed):
        return False
    wps = pick_place_waypoints((x, y, PICK_Z), speed, drop, CONFIG)
    try:
        pick = plan_pick(start, wps, gen, CONFIG)
    except PlannerInputError:
        return False
    return pick.phase_start("seal") <= t + 1e-9


def earliest_feasible(robot, start, item, speed, drop, t_end: float) -> float | None:
    """First feasible meeting time on a 0.5 ms grid (coarse 5 ms scan, then refined), or None
    when none up to `t_end` [s] is feasible."""
    coarse = np.arange(0.0, t_end + COARSE, COARSE)
    for k, t in enumerate(coarse):
        if feasible(robot, start, item, speed, float(t), drop):
            if k == 0:
                return 0.0
            for tf in np.arange(coarse[k - 1] + FINE, t + FINE / 2, FINE):
                if feasible(robot, start, item, speed, float(tf), drop):
                    return float(tf)
            return float(t)
    return None


def _items_in_window(robot, rng, n: int, speed: float):
    """`n` random items inside the window now (and for a while: 0.3 s of belt travel)."""
    geom, _ = robot
    items = []
    while len(items) < n:
        x, y = rng.uniform(-0.45, 0.25), rng.uniform(-0.35, 0.35)
        if in_window(geom, x, y, speed) and in_window(geom, x + 0.3 * speed, y, speed):
            items.append((x, y))
    return items


@pytest.mark.parametrize("speed", SPEEDS)
def test_items_in_the_window_are_met_at_the_earliest_feasible_time(robot, speed):
    rng = np.random.default_rng(int(speed * 1e4) + 101)
    for k, item in enumerate(_items_in_window(robot, rng, 3, speed)):
        start = State.at_rest(BINS[k % 3])
        drop = BINS[(k + 1) % 3]
        hit = intercept_item(start, item, speed, drop, robot[1], PICK_Z, with_plan=False)
        assert hit.feasible, hit.reason
        where = (speed, item, k)
        assert feasible(robot, start, item, speed, hit.meet_time, drop), where
        best = earliest_feasible(robot, start, item, speed, drop, hit.meet_time)
        assert best is not None, where
        assert hit.meet_time >= best - FINE - 1e-9, (where, hit.meet_time, best)
        assert hit.meet_time - best <= LATE_TOL, (where, hit.meet_time, best)


@pytest.mark.parametrize("speed", SPEEDS)
def test_meeting_ten_ms_earlier_is_infeasible(robot, speed):
    # The quick form of the check above, on more items: the answer is feasible, and the same
    # item could not have been met `LATE_TOL` sooner (the robot was still on its way).
    rng = np.random.default_rng(int(speed * 1e4) + 202)
    for k, item in enumerate(_items_in_window(robot, rng, 12, speed)):
        start = State.at_rest(BINS[k % 3])
        hit = intercept_item(start, item, speed, BINS[0], robot[1], PICK_Z, with_plan=False)
        assert hit.feasible, hit.reason
        t = hit.meet_time
        assert t > 0.05, (item, t)  # the cup needs time to get there from a bin
        assert feasible(robot, start, item, speed, t, BINS[0]), (item, t)
        assert not feasible(robot, start, item, speed, t - LATE_TOL, BINS[0]), (item, t)


@pytest.mark.parametrize("y", [-0.3, 0.0, 0.25])
def test_an_upstream_item_is_met_where_it_enters_the_window(robot, y):
    geom, gen = robot
    speed, item = 0.2775, (-1.0, y)
    start = State.at_rest(BINS[0])
    hit = intercept_item(start, item, speed, BINS[0], gen, PICK_Z, with_plan=False)
    assert hit.feasible, hit.reason
    # Where the item enters the window, on a 0.5 ms grid: the robot is there long before.
    ts = np.arange(0.0, 6.0, FINE)
    entry = next(float(t) for t in ts if in_window(geom, item[0] + speed * t, y, speed))
    assert feasible(robot, start, item, speed, hit.meet_time, BINS[0])
    best = earliest_feasible(robot, start, item, speed, BINS[0], hit.meet_time)
    assert best is not None and best >= entry - 1e-9
    assert best - entry < 0.01  # plans right at the edge may leave the workspace
    assert 0.0 <= hit.meet_time - best <= UPSTREAM_TOL, (hit.meet_time, best, entry)


@pytest.mark.parametrize("y", [-0.25, 0.0, 0.2])
def test_items_near_the_downstream_edge_are_met_earliest_or_rightly_refused(robot, y):
    # Items placed 0 to 12 cm upstream of where the window ends at this y, at the top speed:
    # the far ones are met (at the earliest time), the near ones refused (no time is feasible).
    geom, gen = robot
    speed = 0.2775
    xs = np.arange(0.0, 0.7, 0.001)
    edge = max(float(x) for x in xs if in_window(geom, x, y, speed))
    start = State.at_rest(BINS[1])
    outcomes = []
    for back in (0.12, 0.08, 0.05, 0.03, 0.01):
        item = (edge - back, y)
        hit = intercept_item(start, item, speed, BINS[0], gen, PICK_Z, with_plan=False)
        t_exit = back / speed
        best = earliest_feasible(robot, start, item, speed, BINS[0], t_exit)
        outcomes.append(hit.feasible)
        if hit.feasible:
            assert best is not None, (item, hit.meet_time)
            assert hit.meet_time <= t_exit + 1e-9
            assert 0.0 <= hit.meet_time - best + FINE <= LATE_TOL + FINE, (item, best)
        else:
            assert "leaves the reachable window" in hit.reason, hit.reason
            assert best is None, (item, best, hit.reason)
    assert outcomes[0] and not outcomes[-1], outcomes  # both kinds occur at this edge


@pytest.mark.xfail(
    strict=True,
    reason="the fixed-point iteration keeps its overshoot when the pick shortens as the item "
    "rides towards the robot's start: met 7.8 ms later than feasible, TIME_TOL documents 1 ms",
)
def test_documented_one_ms_slack_when_the_item_rides_towards_the_robot(robot):
    # Robot resting over the aluminium bin (+x side), item upstream on the -x side: every
    # millimetre the belt carries it shortens the approach, so D(T) decreases with T.
    speed, item = 0.2775, (-0.2968128449311421, 0.1088507914200178)
    start, drop = State.at_rest(BINS[2]), BINS[0]
    hit = intercept_item(start, item, speed, drop, robot[1], PICK_Z, with_plan=False)
    assert hit.feasible, hit.reason
    best = earliest_feasible(robot, start, item, speed, drop, hit.meet_time)
    assert best is not None
    assert hit.meet_time - best <= LATE_TOL  # within the general bound: 7.8 ms
    assert hit.meet_time - best <= DOC_TOL, (hit.meet_time, best)
