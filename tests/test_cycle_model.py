"""The decision managers' cycle-time model against ruckig: exact 1-D closed form, calibrated
pick and place times on fresh random picks, speed."""

from __future__ import annotations

import time

import numpy as np
import pytest
from ruckig import InputParameter, Ruckig, Trajectory

from planner.errors import PlannerInputError
from planner.motion.cycle_calibration import draw_samples, fitted_model
from planner.motion.cycle_model import CycleTimeModel, jerk_limited_time
from planner.motion.limits import limits_for_payload
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from sim.cell.executor import lumped_dynamics
from sim.cell.robot import geometry_from_model
from sim.model.mjcf import load_robot

BINS = ((0.0, -0.51, 0.06), (-0.21, 0.51, 0.06), (0.21, 0.51, 0.06))
N_FRESH = 60


def _ruckig_1d(d, v, a, j):
    otg, inp, traj = Ruckig(1), InputParameter(1), Trajectory(1)
    inp.current_position, inp.target_position = [0.0], [d]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [v], [a], [j]
    otg.calculate(inp, traj)
    return traj.duration


def test_closed_form_equals_ruckig_1d():
    rng = np.random.default_rng(3)
    for _ in range(300):
        d = 10 ** rng.uniform(-4, 0.5)
        v, a, j = rng.uniform(0.5, 10), rng.uniform(5, 100), rng.uniform(200, 20000)
        assert jerk_limited_time(d, v, a, j) == pytest.approx(_ruckig_1d(d, v, a, j), abs=1e-9)


@pytest.fixture(scope="module")
def fresh():
    model = load_robot()
    geom = geometry_from_model(model)
    gen = RuckigTrajectoryGenerator(limits_for_payload(0.1), geom, lumped_dynamics(model, geom))
    return draw_samples(gen, CycleTimeModel(), BINS, np.random.default_rng(11), N_FRESH)


def test_pick_and_place_times_against_ruckig(fresh):
    model = CycleTimeModel()
    pick = np.array(
        [
            model.time_to_pick(s, i, v)
            for s, i, v in zip(fresh.starts, fresh.items, fresh.speeds, strict=True)
        ]
    )
    err = pick - fresh.pick_planned
    meet = np.c_[fresh.items[:, 0] + fresh.speeds * fresh.pick_planned, fresh.items[:, 1]]
    meet = np.c_[meet, np.full(len(meet), model.pick_z)]
    place = np.array([model.time_to_place(m, b) for m, b in zip(meet, fresh.bins, strict=True)])
    err_place = place - fresh.place_planned
    print(
        f"pick: mean {1e3 * err.mean():+.1f} ms, sd {1e3 * err.std():.1f} ms, "
        f"max |err| {1e3 * np.abs(err).max():.1f} ms over {N_FRESH} ruckig picks; "
        f"place: mean {1e3 * err_place.mean():+.1f} ms, sd {1e3 * err_place.std():.1f} ms, "
        f"max |err| {1e3 * np.abs(err_place).max():.1f} ms"
    )
    assert abs(err.mean()) < 0.003 and err.std() < 0.006
    # The rare large errors: under-estimates where the motor checks slowed a segment (the
    # closed form cannot see that), over-estimates on short hops where the blended corner skips
    # the 25 mm approach.
    assert np.mean(np.abs(err) < 0.005) > 0.9
    assert err.min() > -0.030 and err.max() < 0.040
    assert abs(err_place.mean()) < 0.003 and np.abs(err_place).max() < 0.010
    # The calibrated model beats the raw closed form (it is not a constant either).
    raw = np.abs(fresh.pick_raw - fresh.pick_planned)
    assert np.mean(np.abs(err)) < np.mean(raw)
    assert np.ptp(pick) > 0.1


def test_refit_is_close_to_the_stored_calibration(fresh):
    refit = fitted_model(CycleTimeModel(), fresh)
    model = CycleTimeModel()
    for t_raw in (0.05, 0.15, 0.25):
        stored = model.pick_coef[0] + model.pick_coef[1] * t_raw
        new = refit.pick_coef[0] + refit.pick_coef[1] * t_raw
        assert abs(stored - new) < 0.01


def test_cycle_time_is_pick_plus_place():
    model = CycleTimeModel()
    start, item, speed, drop = (0.0, -0.51, 0.06), (0.1, 0.2), 0.2775, (0.21, 0.51, 0.06)
    t = model.time_to_pick(start, item, speed)
    meet = (item[0] + speed * t, item[1], model.pick_z)
    assert model.cycle_time(start, item, speed, drop) == pytest.approx(
        t + model.time_to_place(meet, drop)
    )
    # Moving item: the meeting point is downstream, so a move towards +x takes longer.
    assert model.time_to_pick((-0.3, 0, 0.1), (0.0, 0.0), 0.2775) > model.time_to_pick(
        (-0.3, 0, 0.1), (0.0, 0.0), 0.0
    )


def test_fast_enough_for_the_decision_managers():
    model = CycleTimeModel()
    n = 3000
    t0 = time.thread_time()  # CPU time: a busy machine slows the wall clock, not this
    for k in range(n):
        model.time_to_pick((0.0, -0.51, 0.06), (0.001 * (k % 300), 0.2), 0.2775)
    per_call = (time.thread_time() - t0) / n
    print(f"time_to_pick: {1e6 * per_call:.1f} us CPU per call")
    # About 15 us; the bound only catches a pathological slowdown (the figures are the
    # benchmarks': benchmarks/bench_decision.py).
    assert per_call < 100e-6


def test_refusals():
    with pytest.raises(PlannerInputError):
        CycleTimeModel(pick_coef=(0.0, -1.0))
