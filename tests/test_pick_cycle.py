"""Pick-and-place chains: phases, sealing at the belt's velocity, blending never slower."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import PlannerInputError
from planner.motion import blending
from planner.motion.blending import Waypoint, plan_chain, search_corners
from planner.motion.limits import limits_for_payload
from planner.motion.motor_rates import motor_rates
from planner.motion.pick_cycle import (
    PickPlaceConfig,
    cycle1_waypoints,
    pick_place_waypoints,
    plan_cycle1,
    plan_pick_place,
)
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from planner.motion.trajectory import State
from sim.cell.executor import lumped_dynamics
from sim.cell.robot import geometry_from_model
from sim.model.mjcf import load_robot

A = np.array([-0.1525, 0.0, 0.05])


@pytest.fixture(scope="module")
def gen():
    model = load_robot()
    geom = geometry_from_model(model)
    return RuckigTrajectoryGenerator(
        limits_for_payload(1.0), geom, lumped_dynamics(model, geom, 1.0)
    )


def test_pick_place_phases(gen):
    start = State.at_rest([0.0, -0.51, 0.06])
    plan = plan_pick_place(start, [0.1, 0.2, 0.02], 0.2775, [0.21, 0.51, 0.06], gen)
    labels = [s.label for s in plan.chain.segments]
    assert labels == ["approach", "descend", "seal", "lift", "transfer", "release"]
    # Touch down on the item at the belt's velocity and seal 35 ms moving with it.
    for t in np.linspace(plan.contact_time, plan.lift_time, 8):
        p, v, a = plan.chain.at_time(t)
        assert np.allclose(v, [0.2775, 0.0, 0.0, 0.0], atol=1e-9)
        assert abs(p[2] - 0.02) < 1e-9
    assert plan.lift_time - plan.contact_time == pytest.approx(0.035, abs=1e-12)
    p, v, _ = plan.chain.at_time(plan.contact_time)
    assert np.allclose(p[:3], [0.1, 0.2, 0.02], atol=1e-9)
    # Release at rest over the bin, 35 ms, to the end of the plan.
    assert plan.duration - plan.release_time == pytest.approx(0.035, abs=1e-12)
    for t in (plan.release_time, plan.duration):
        p, v, _ = plan.chain.at_time(t)
        assert np.allclose(p[:3], [0.21, 0.51, 0.06], atol=1e-9)
        assert np.allclose(v, 0.0, atol=1e-9)
    # The cup never dips below the item's top on the way down or up.
    lows = [s.position_range(2)[0] for s in plan.chain.segments if hasattr(s, "position_range")]
    assert min(lows) >= 0.02 - 1e-9


def test_contact_time_is_met_exactly(gen):
    start = State.at_rest([0.0, -0.51, 0.06])
    plan = plan_pick_place(
        start, [0.0, 0.0, 0.02], 0.185, [0.0, -0.51, 0.06], gen, contact_time=0.5
    )
    assert plan.contact_time == pytest.approx(0.5, abs=1e-9)


def test_cycle1_blending_faster_and_on_its_path(gen):
    blended = plan_cycle1(A, gen)
    rest = plan_cycle1(A, gen, blend=False)
    assert blended.duration < rest.duration - 0.05  # blending pays on Cycle 1
    samples = blended.sample(0.001)
    z = samples.position[:, 2]
    assert z.min() >= A[2] - 1e-9  # never below the pick/place height
    assert z.max() >= A[2] + 0.025 - 1e-9  # rises the full 25 mm
    x = samples.position[:, 0]
    assert x.min() >= A[0] - 1e-3 and x.max() <= A[0] + 0.305 + 1e-3
    # While within 5 mm of the belt level the cup is within the 25 mm zone of A or B.
    low = z < A[2] + 0.005
    near = np.minimum(np.abs(x - A[0]), np.abs(x - A[0] - 0.305))
    assert np.all(near[low] <= 0.025 + 1e-9)
    # 90 deg of axis 4 at B, back to 0 at A, 35 ms of vacuum at each end.
    t_place = blended.phase_start("vacuum_place")
    assert blended.at_time(t_place)[0][3] == pytest.approx(np.pi / 2, abs=1e-9)
    assert blended.at_time(blended.duration)[0][3] == pytest.approx(0.0, abs=1e-9)
    assert blended.duration - blended.phase_start("vacuum_pick") == pytest.approx(0.035)


def test_zoneless_cycle1_stays_on_the_lines(gen):
    wps = cycle1_waypoints(A, zone=0.0)
    chain = plan_chain(State.at_rest(A), wps, gen)
    s = chain.sample(0.001)
    x, z = s.position[:, 0], s.position[:, 2]
    # Without a zone, the cup leaves and reaches the belt level only straight up and down.
    low = z < A[2] + 0.02
    near = np.minimum(np.abs(x - A[0]), np.abs(x - A[0] - 0.305))
    assert np.max(near[low]) < 1e-6
    assert chain.duration >= plan_cycle1(A, gen).duration


def test_motor_speeds_of_cycle1_within_limit(gen):
    s = plan_cycle1(A, gen).sample(0.001)
    qd = motor_rates(gen.geometry, s.position[:, :3], s.velocity[:, :3]).qdot
    assert np.max(np.abs(qd)) <= gen.limits.motor_velocity


def test_refusals(gen):
    with pytest.raises(PlannerInputError):
        PickPlaceConfig(seal_time=-0.01)
    with pytest.raises(PlannerInputError):
        Waypoint(np.zeros(4), velocity=None, dwell=0.035)
    with pytest.raises(PlannerInputError):
        plan_chain(State.at_rest(A), [Waypoint(np.r_[A, 0.0])], gen)  # ends on a corner
    with pytest.raises(PlannerInputError):
        plan_pick_place(State.at_rest(A), [1.2, 0.0, 0.02], 0.185, [0.0, -0.51, 0.06], gen)


def test_a_chain_without_corners_plans_each_segment_once(gen, monkeypatch):
    """Without corners the blended chain is the rest-corner chain: each segment is planned
    (motor checks included) once, and the chain is the one planned without blending."""
    start = State.at_rest([0.1, 0.2, 0.02])
    waypoints = [
        Waypoint(np.array([0.1, 0.2, 0.08, 0.0]), velocity=np.zeros(4), label="lift"),
        Waypoint(np.array([0.21, 0.51, 0.06, 0.5]), np.zeros(4), 0.035, "transfer", "release"),
    ]
    unblended = plan_chain(start, waypoints, gen, blend=False)
    labels = []
    plan_many = gen.plan_many

    def counted(requests):
        labels.extend(label for _, _, label, *_ in requests)
        return plan_many(requests)

    monkeypatch.setattr(gen, "plan_many", counted)
    chain = plan_chain(start, waypoints, gen, blend=True)
    assert labels == ["lift", "transfer"]
    assert [s.duration for s in chain.segments] == [s.duration for s in unblended.segments]


def test_corner_search_ends_only_where_more_sweeps_change_nothing(gen, monkeypatch):
    """The coordinate descent stops after a sweep that changed nothing, and after one sweep
    of a single corner: the corners and duration are those of every sweep run."""
    starts = [State.at_rest([0.0, -0.51, 0.06]), State.at_rest([-0.3, 0.2, 0.15], 0.4)]
    chains = [
        (
            s,
            pick_place_waypoints([0.1, 0.2, 0.02], 0.2775, [0.21, 0.51, 0.06], PickPlaceConfig())[
                :2
            ],
        )
        for s in starts
    ]
    chains.append((State.at_rest(A), cycle1_waypoints(A)))
    rng = np.random.default_rng(0)
    for _ in range(12):  # two corners: some improve on a second sweep
        points = [np.r_[rng.uniform(-0.3, 0.3, 2), rng.uniform(0.03, 0.2), 0.0] for _ in range(4)]
        waypoints = [Waypoint(p) for p in points[1:3]] + [Waypoint(points[3], np.zeros(4))]
        chains.append((State(points[0]), waypoints))
    for sweeps in (2, 3):
        found = [search_corners(s, wps, gen, sweeps=sweeps) for s, wps in chains]
        with monkeypatch.context() as patch:
            patch.setattr(blending, "_settled", lambda best, before, corners: False)
            every = [search_corners(s, wps, gen, sweeps=sweeps) for s, wps in chains]
        for (corners, duration), (all_corners, all_duration) in zip(found, every, strict=True):
            assert duration == all_duration
            assert corners.keys() == all_corners.keys()
            for k, (offset, velocity) in corners.items():
                np.testing.assert_array_equal(offset, all_corners[k][0])
                np.testing.assert_array_equal(velocity, all_corners[k][1])
