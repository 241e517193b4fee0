"""Ruckig trajectories: boundary states, every limit, the workspace, blending never slower.

The property test plans 1000 seeded random pick-and-place pairs in the cell (start at rest
somewhere in the workspace, item on the belt at a thesis belt speed, drop over a random bin)
and checks each whole chain sampled every millisecond.
"""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import PlannerInputError
from planner.motion.blending import plan_chain
from planner.motion.kinematics import inverse_kinematics, jacobian, reachable_mask, row_sums
from planner.motion.limits import MotionLimits, limits_for_payload
from planner.motion.motor_rates import motor_rates
from planner.motion.pick_cycle import PickPlaceConfig, pick_place_waypoints
from planner.motion.ruckig_trajectory import (
    CHECK_DT,
    TORQUE_MARGIN,
    RuckigTrajectoryGenerator,
    motor_speeds,
    motor_torques,
    stacked_xyz,
)
from planner.motion.trajectory import Chain, Dwell, State
from sim.cell.executor import lumped_dynamics
from sim.cell.robot import geometry_from_model
from sim.model.mjcf import load_robot

N_PAIRS = 1000
BOUNDARY_TOL = 1e-8
BINS = ((0.0, -0.51, 0.06), (-0.21, 0.51, 0.06), (0.21, 0.51, 0.06))
SPEEDS = (0.185, 0.222, 0.2775)
PICK_Z = 0.02


@pytest.fixture(scope="module")
def robot():
    model = load_robot()
    geom = geometry_from_model(model)
    dyn = lumped_dynamics(model, geom, 0.1)
    gen = RuckigTrajectoryGenerator(limits_for_payload(0.1), geom, dyn)
    return geom, dyn, gen


def _random_pair(rng, geom):
    while True:
        start = np.array(
            [rng.uniform(-0.45, 0.45), rng.uniform(-0.45, 0.45), rng.uniform(0.03, 0.2)]
        )
        pick = np.array([rng.uniform(-0.4, 0.4), rng.uniform(-0.35, 0.35), PICK_Z])
        drop = np.array(BINS[rng.integers(3)])
        if np.all(reachable_mask(geom, np.stack([start, pick, pick + [0, 0, 0.025]]))):
            return start, pick, float(rng.choice(SPEEDS)), drop


def _check_chain(chain: Chain, start: State, wps, geom, dyn, limits: MotionLimits):
    # Boundary states: the chain's start, every stop's state, continuity between segments.
    p, v, a = chain.at_time(0.0)
    assert np.max(np.abs(np.r_[p - start.position, v - start.velocity])) < BOUNDARY_TOL
    ends = {s.label: s.end for s in chain.segments}
    for wp in wps:
        if wp.velocity is not None:
            end = ends[wp.label]
            assert np.max(np.abs(end.position - wp.position)) < BOUNDARY_TOL
            assert np.max(np.abs(end.velocity - wp.velocity)) < BOUNDARY_TOL
    for prev, seg in zip(chain.segments, chain.segments[1:], strict=False):
        gap = np.r_[prev.end.position - seg.start.position, prev.end.velocity - seg.start.velocity]
        assert np.max(np.abs(gap)) < BOUNDARY_TOL
    # Limits, sampled every millisecond on every ruckig segment.
    for seg in chain.segments:
        if isinstance(seg, Dwell):
            continue
        times, pos, vel, acc = seg.sample_states(0.001)
        assert np.all(np.abs(vel) <= limits.max_velocity * (1 + 1e-9) + 1e-12)
        assert np.all(np.abs(acc) <= limits.max_acceleration * (1 + 1e-9) + 1e-9)
        dt = np.diff(times)[:, None]
        ok = dt[:, 0] > 1e-7
        jerk = np.abs(np.diff(acc, axis=0))[ok] / dt[ok]
        assert np.all(jerk <= limits.max_jerk * (1 + 1e-6))
        assert np.all(reachable_mask(geom, pos[:, :3]))
        qd = motor_speeds(geom, pos[:, :3], vel[:, :3])
        assert np.max(np.abs(qd)) <= limits.motor_velocity * 1.01
        tau = motor_torques(geom, dyn, pos[:, :3], vel[:, :3], acc[:, :3])
        assert np.max(np.abs(tau)) <= dyn.torque_limit * TORQUE_MARGIN * 1.01


def test_random_pick_place_pairs(robot):
    geom, dyn, gen = robot
    rng = np.random.default_rng(20260101)
    config = PickPlaceConfig()
    gains = []
    for _ in range(N_PAIRS):
        start, pick, speed, drop = _random_pair(rng, geom)
        wps = pick_place_waypoints(pick, speed, drop, config)
        state = State.at_rest(start)
        blended = plan_chain(state, wps, gen, blend=True)
        rest = plan_chain(state, wps, gen, blend=False)
        _check_chain(blended, state, wps, geom, dyn, gen.limits)
        assert blended.duration <= rest.duration + 1e-12
        gains.append(rest.duration - blended.duration)
    # Blending pays on most pairs, not only on a lucky few.
    assert np.median(gains) > 0.005


def test_rest_to_rest_segment_hits_goal(robot):
    _, _, gen = robot
    a = State.at_rest([-0.2, 0.1, 0.05], 0.3)
    b = State([0.25, -0.2, 0.12, -1.0], [0.3, 0.0, 0.0, 0.0])
    seg = gen.plan(a, b)
    p, v, acc = seg.at_time(seg.duration)
    assert np.allclose(p, b.position, atol=BOUNDARY_TOL)
    assert np.allclose(v, b.velocity, atol=BOUNDARY_TOL)
    assert np.allclose(acc, 0.0, atol=BOUNDARY_TOL)


def test_motor_speed_limit_forces_a_retime(robot):
    geom, _, _ = robot
    slow_motors = MotionLimits(motor_velocity=2.0)
    gen = RuckigTrajectoryGenerator(slow_motors, geom)
    seg = gen.plan(State.at_rest([-0.3, 0.0, 0.05]), State.at_rest([0.3, 0.0, 0.05]))
    assert gen.last_retimes > 0
    times, pos, vel, _ = seg.sample_states(0.0005)
    assert np.max(np.abs(motor_speeds(geom, pos[:, :3], vel[:, :3]))) <= 2.0 * 1.01
    free = RuckigTrajectoryGenerator(slow_motors, None).plan(
        State.at_rest([-0.3, 0.0, 0.05]), State.at_rest([0.3, 0.0, 0.05])
    )
    assert seg.duration > free.duration * 1.5


def test_goal_outside_workspace_is_refused(robot):
    _, _, gen = robot
    with pytest.raises(PlannerInputError):
        gen.plan(State.at_rest([0.0, 0.0, 0.05]), State.at_rest([1.5, 0.0, 0.05]))


def test_limits_validation_and_payload_dependence():
    with pytest.raises(PlannerInputError):
        MotionLimits(tcp_acceleration=-1.0)
    with pytest.raises(PlannerInputError):
        limits_for_payload(3.5)
    with pytest.raises(PlannerInputError):
        State([0.0, 0.0, 0.0])
    accels = [limits_for_payload(m).tcp_acceleration for m in (0.0, 1.0, 2.0, 3.0)]
    assert accels[0] == accels[1] == 100.0  # datasheet
    assert accels[1] > accels[2] > accels[3]
    assert limits_for_payload(0.5).tcp_velocity == 10.0


def test_motor_rates_match_kinematics_and_finite_differences(robot):
    geom, _, _ = robot
    rng = np.random.default_rng(5)
    p = np.c_[rng.uniform(-0.3, 0.3, 20), rng.uniform(-0.3, 0.3, 20), rng.uniform(0.03, 0.2, 20)]
    v, a = rng.normal(size=(20, 3)), 50.0 * rng.normal(size=(20, 3))
    rates = motor_rates(geom, p, v, a)
    assert np.allclose(rates.jac, jacobian(geom, rates.q), atol=1e-12)
    h = 1e-5

    def q_at(t):
        return inverse_kinematics(geom, p + v * t + 0.5 * a * t * t)

    assert np.allclose(rates.qdot, (q_at(h) - q_at(-h)) / (2 * h), atol=1e-7)
    assert np.allclose(rates.qddot, (q_at(h) - 2 * q_at(0.0) + q_at(-h)) / h**2, atol=1e-3)


def test_a_move_on_a_ruckig_profile_boundary_is_still_planned():
    """45 mm rest to rest at 100 m/s^2 and a 15 ms jerk ramp is exactly 2 a^3 / j^2, where
    ruckig 0.19 throws; the generator plans it with the jerk nudged down instead."""
    limits = MotionLimits()
    generator = RuckigTrajectoryGenerator(limits)
    start = State.at_rest(np.array([0.05478467492858174, -0.2302132862361297, 0.1]))
    goal = State.at_rest(np.array([-0.5017158856382833, -0.3384306551300296, 0.055]))
    segment = generator.plan(start, goal)
    p, v, _ = segment.at_time(segment.duration)
    np.testing.assert_allclose(p, goal.position, atol=1e-8)
    np.testing.assert_allclose(v, 0.0, atol=1e-8)


def test_vectorised_states_are_ruckigs_to_the_bit(robot):
    """`Chain.states_at` (numpy over ruckig's phases) gives exactly what `at_time` gives, one
    time at a time: the executor's set-points and every plan check are sampled with it."""
    geom, _, gen = robot
    rng = np.random.default_rng(7)
    config = PickPlaceConfig()
    for _ in range(60):
        start, pick, speed, drop = _random_pair(rng, geom)
        chain = plan_chain(
            State.at_rest(start), pick_place_waypoints(pick, speed, drop, config), gen
        )
        assert any(isinstance(s, Dwell) for s in chain.segments)
        times = np.concatenate(
            [
                np.arange(0.0, chain.duration, 0.001),
                chain.starts,  # every segment's ends
                rng.uniform(-0.05, chain.duration + 0.05, 200),  # and outside it (clamped)
            ]
        )
        one_by_one = np.array([np.concatenate(chain.at_time(float(t))) for t in times])
        at_once = np.concatenate(chain.states_at(times), axis=1)
        np.testing.assert_array_equal(at_once, one_by_one)


def test_vectorised_states_of_coordinates_that_finish_early_are_ruckigs_to_the_bit(robot):
    """A coordinate that does not move (or arrives before the others) ends its profile before
    the segment does, and then keeps its final state: `states_at` gives what `at_time` gives
    there too (also for a segment stretched to a minimum duration)."""
    _, _, gen = robot
    start = State.at_rest([-0.2, 0.1, 0.05], 0.3)
    goals = [
        State.at_rest([0.25, 0.1, 0.05], 0.3),  # x alone moves
        State([0.1, 0.1, 0.12, 0.3], [0.2, 0.0, 0.0, 0.0]),  # y and axis 4 stay
        State.at_rest([-0.2, 0.1, 0.08], 0.35),  # a short z move and a small turn
    ]
    for goal in goals:
        for minimum_duration in (None, 0.4):
            segment = gen.plan(start, goal, minimum_duration=minimum_duration)
            times = np.concatenate(
                [segment.sample_states(0.001)[0], np.linspace(-0.01, segment.duration + 0.01, 97)]
            )
            one_by_one = np.array([np.concatenate(segment.at_time(float(t))) for t in times])
            at_once = np.concatenate(segment.states_at(times), axis=1)
            np.testing.assert_array_equal(at_once, one_by_one)


def test_limit_ratios_are_motor_rates_own_numbers_to_the_bit(robot):
    """`limit_ratios` solves the inverse kinematics once for the workspace check and the motor
    rates: its ratios are exactly those of `motor_rates` (which solves it again) on the
    segment's samples, and a segment leaving the workspace is (inf, inf)."""
    geom, dyn, gen = robot
    rng = np.random.default_rng(11)
    for _ in range(20):
        start, pick, speed, _ = _random_pair(rng, geom)
        goal = State(np.append(pick, 0.5), [speed, 0.0, 0.0, 0.0])
        segment = gen.plan_unchecked(State.at_rest(start), goal)
        _, pos, vel, acc = segment.sample_states(CHECK_DT)
        rates = motor_rates(geom, pos[:, :3], vel[:, :3], acc[:, :3])
        tau = dyn.torque(rates.q, rates.qdot, rates.qddot, rates.jac, acc[:, :3])
        expected = (
            float(np.max(np.abs(rates.qdot))) / gen.limits.motor_velocity,
            float(np.max(np.abs(tau))) / (TORQUE_MARGIN * dyn.torque_limit),
        )
        assert gen.limit_ratios(segment) == expected
    away = gen.plan_unchecked(State.at_rest([0.0, 0.0, 0.05]), State.at_rest([1.5, 0.0, 0.05]))
    assert gen.limit_ratios(away) == (np.inf, np.inf)


def test_ruckig_limits_are_the_per_coordinate_limits():
    for limits in (limits_for_payload(2.0), limits_for_payload(0.5).slowed(1.37)):
        assert limits.ruckig_limits == (
            tuple(limits.max_velocity),
            tuple(limits.max_acceleration),
            tuple(limits.max_jerk),
        )


def _reference_ratios(geom, dyn, gen, segment):
    """`limit_ratios` as the generator first computed it: one segment, `motor_rates` and
    `LumpedDynamics.torque` on its samples every `CHECK_DT`."""
    _, pos, vel, acc = segment.sample_states(CHECK_DT)
    if not np.all(reachable_mask(geom, pos[:, :3])):
        return np.inf, np.inf
    rates = motor_rates(geom, pos[:, :3], vel[:, :3], acc[:, :3])
    tau = dyn.torque(rates.q, rates.qdot, rates.qddot, rates.jac, acc[:, :3])
    return (
        float(np.max(np.abs(rates.qdot))) / gen.limits.motor_velocity,
        float(np.max(np.abs(tau))) / (TORQUE_MARGIN * dyn.torque_limit),
    )


def test_segments_checked_together_have_their_own_ratios_to_the_bit(robot):
    """The motor checks of several segments evaluated in one pass (`limit_ratios_of`: their
    samples stacked) give each segment exactly the ratios it has checked alone, a segment
    leaving the workspace among them included."""
    geom, dyn, gen = robot
    rng = np.random.default_rng(12)
    segments = []
    for _ in range(30):
        start, pick, speed, drop = _random_pair(rng, geom)
        goal = State(np.append(pick, 0.5), [speed, 0.0, 0.0, 0.0])
        segments.append(gen.plan_unchecked(State.at_rest(start), goal))
        segments.append(gen.plan_unchecked(goal, State.at_rest(drop)))
    segments.insert(
        7, gen.plan_unchecked(State.at_rest([0.0, 0.0, 0.05]), State.at_rest([1.5, 0, 0.05]))
    )
    expected = [_reference_ratios(geom, dyn, gen, s) for s in segments]
    assert gen.limit_ratios_of(segments) == expected
    assert [gen.limit_ratios_of([s])[0] for s in segments[:9]] == expected[:9]


def test_segments_planned_together_are_those_planned_alone(robot):
    """`plan_many` plans each request exactly as `plan` does alone: the same re-plans, the
    same segment (duration, limits and states to the bit), the same refusal."""
    geom, _, gen = robot
    rng = np.random.default_rng(13)
    requests = []
    for _ in range(12):
        start, pick, speed, drop = _random_pair(rng, geom)
        goal = State(np.append(pick, 0.5), [speed, 0.0, 0.0, 0.0])
        requests.append((State.at_rest(start), goal, "approach", None, 1.0))
        requests.append((goal, State.at_rest(drop), "transfer", 0.6, 1.3))
    requests.insert(
        3, (State.at_rest([0.0, 0.0, 0.05]), State.at_rest([1.5, 0, 0.05]), "away", None, 1.0)
    )
    together = gen.plan_many(requests)
    for request, segment in zip(requests, together, strict=True):
        try:
            alone = gen.plan(*request)
        except PlannerInputError as exc:
            assert isinstance(segment, PlannerInputError) and str(segment) == str(exc)
            continue
        assert segment.duration == alone.duration and segment.limits == alone.limits
        times = np.linspace(0.0, alone.duration, 57)
        for a, b in zip(segment.states_at(times), alone.states_at(times), strict=True):
            np.testing.assert_array_equal(a, b)


def test_stacked_check_samples_are_each_segments_own(robot):
    """The check samples of many segments evaluated in one pass are, segment by segment, the
    times and states `sample_states` gives each alone (x, y and z)."""
    geom, _, gen = robot
    rng = np.random.default_rng(14)
    segments = []
    for _ in range(10):
        start, pick, speed, drop = _random_pair(rng, geom)
        goal = State(np.append(pick, 0.5), [speed, 0.0, 0.0, 0.0])
        segments.append(gen.plan_unchecked(State.at_rest(start), goal, minimum_duration=0.3))
        segments.append(gen.plan_unchecked(goal, State.at_rest(drop)))
    tables = [s._phase_tables() for s in segments]
    sizes, pos, vel, acc = stacked_xyz(tables, [s.duration for s in segments], CHECK_DT)
    rows = np.cumsum(np.r_[0, sizes])
    for k, segment in enumerate(segments):
        _, p, v, a = segment.sample_states(CHECK_DT)
        got = slice(rows[k], rows[k + 1])
        np.testing.assert_array_equal(pos[got], p[:, :3])
        np.testing.assert_array_equal(vel[got], v[:, :3])
        np.testing.assert_array_equal(acc[got], a[:, :3])


def test_row_sums_add_as_numpy_sums():
    """`row_sums` (three leg-major rows added in order) is `np.sum(..., axis=-1)` of the
    row-major array to the bit, on values of very different magnitudes."""
    rng = np.random.default_rng(15)
    x = rng.normal(size=(5000, 3, 3)) * 10.0 ** rng.integers(-8, 8, size=(5000, 3, 3))
    legs = np.ascontiguousarray(x.transpose(1, 2, 0))
    np.testing.assert_array_equal(row_sums(legs), np.sum(x, axis=-1))
