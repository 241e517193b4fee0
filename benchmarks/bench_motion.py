"""Motion planning and execution figures: ruckig planning time per segment, whole pick plans,
the cycle-time model's speed and error, the physics step cost while the robot moves, and ABB's
Cycle 1 time at 0.1, 1 and 3 kg.

Run: `.venv/bin/python benchmarks/bench_motion.py [--quick] [--fit]`
(`--fit` refits the cycle-time model's calibration on 250 ruckig picks and prints it.)
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

from planner.motion.cycle_calibration import draw_samples, fitted_model
from planner.motion.cycle_model import CycleTimeModel
from planner.motion.intercept import intercept_item
from planner.motion.kinematics import inverse_kinematics
from planner.motion.limits import limits_for_payload
from planner.motion.pick_cycle import plan_cycle1, plan_pick_place
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from planner.motion.trajectory import State
from sim.cell.executor import TrajectoryExecutor, lumped_dynamics
from sim.cell.robot import geometry_from_model, set_configuration
from sim.evaluation.cycle1 import CYCLE1_START, run_cycle1
from sim.model.mjcf import load_robot

BINS = ((0.0, -0.51, 0.06), (-0.21, 0.51, 0.06), (0.21, 0.51, 0.06))
SPEEDS = (0.185, 0.222, 0.2775)
CMD = ".venv/bin/python benchmarks/bench_motion.py"


def _stats_us(seconds: list[float]) -> str:
    us = 1e6 * np.asarray(seconds)
    return f"median {np.median(us):.1f} us, p99 {np.percentile(us, 99):.1f} us (n={us.size})"


def _random_states(rng, n):
    for _ in range(n):
        a = State([rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4), rng.uniform(0.03, 0.2), 0.0])
        b = State(
            [rng.uniform(-0.4, 0.4), rng.uniform(-0.35, 0.35), 0.02, rng.uniform(-1.5, 1.5)],
            [rng.choice(SPEEDS), 0.0, 0.0, 0.0],
        )
        yield a, b


def bench_planning(gen, n, rng):
    raw, checked = [], []
    for a, b in _random_states(rng, n):
        t0 = time.perf_counter()
        gen.plan_unchecked(a, b)
        raw.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        try:
            gen.plan(a, b)
        except ValueError:
            continue
        checked.append(time.perf_counter() - t0)
    print(f"ruckig segment (calculate only): {_stats_us(raw)}")
    print(f"segment with motor speed/torque checks: {_stats_us(checked)}")
    picks, intercepts = [], []
    for _ in range(max(20, n // 50)):
        start = State.at_rest(BINS[rng.integers(3)])
        item = (rng.uniform(-0.3, 0.3), rng.uniform(-0.35, 0.35), 0.02)
        t0 = time.perf_counter()
        plan_pick_place(start, item, 0.2775, BINS[rng.integers(3)], gen)
        picks.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        intercept_item(start, item[:2], 0.2775, BINS[0], gen, 0.02)
        intercepts.append(time.perf_counter() - t0)
    print(f"whole pick-and-place chain (blended, checked): {_stats_us(picks)}")
    print(f"intercept of a moving item + its plan: {_stats_us(intercepts)}")


def bench_model(gen, n, rng, fit):
    model = CycleTimeModel()
    t0 = time.perf_counter()
    for k in range(20000):
        model.time_to_pick((0.0, -0.51, 0.06), (0.001 * (k % 400) - 0.2, 0.2), 0.2775)
    per = (time.perf_counter() - t0) / 20000
    t0 = time.perf_counter()
    for k in range(20000):
        model.time_to_place((0.001 * (k % 400) - 0.2, 0.2, 0.02), (0.21, 0.51, 0.06))
    per_place = (time.perf_counter() - t0) / 20000
    print(
        f"cycle-time model: time_to_pick {1e6 * per:.1f} us, time_to_place {1e6 * per_place:.1f} us"
    )
    if fit:
        samples = draw_samples(gen, model, BINS, np.random.default_rng(1), 250)
        refit = fitted_model(model, samples)
        print(
            f"refit (seed 1, 250 picks): pick_coef {refit.pick_coef}, place_coef {refit.place_coef}"
        )
        model = refit
    s = draw_samples(gen, model, BINS, np.random.default_rng(2), n)
    pick = np.array(
        [model.time_to_pick(a, i, v) for a, i, v in zip(s.starts, s.items, s.speeds, strict=True)]
    )
    meet = np.c_[s.items[:, 0] + s.speeds * s.pick_planned, s.items[:, 1], np.full(n, model.pick_z)]
    place = np.array([model.time_to_place(m, b) for m, b in zip(meet, s.bins, strict=True)])
    for name, err in (("pick", pick - s.pick_planned), ("place", place - s.place_planned)):
        print(
            f"  {name} error vs ruckig (seed 2, n={n}): mean {1e3 * err.mean():+.1f} ms, "
            f"sd {1e3 * err.std():.1f} ms, max |err| {1e3 * np.abs(err).max():.1f} ms"
        )


def bench_physics(repeats):
    model = load_robot()
    geom = geometry_from_model(model)
    gen = RuckigTrajectoryGenerator(limits_for_payload(1.0), geom, lumped_dynamics(model, geom))
    a = np.array(CYCLE1_START)
    chain = plan_cycle1(a, gen)
    data = mujoco.MjData(model)
    set_configuration(model, data, inverse_kinematics(geom, a), 0.0)
    ex = TrajectoryExecutor(model, data, geometry=geom)
    steps, wall = 0, 0.0
    for _ in range(repeats):
        t0 = time.perf_counter()
        log = ex.execute(chain)
        wall += time.perf_counter() - t0
        steps += len(log.time) * ex.substeps
    per_step = wall / steps
    rtf = model.opt.timestep / per_step
    print(
        f"physics while moving (Cycle 1 played {repeats}x, control + IK included): "
        f"{1e6 * per_step:.1f} us per {1e3 * model.opt.timestep:g} ms step, real-time x{rtf:.1f}"
    )
    # mj_step alone: replay the servo commands the executor wrote, on the same motion.
    ctrls = []
    set_configuration(model, data, inverse_kinematics(geom, a), 0.0)
    ex.execute(chain, on_step=lambda _t: ctrls.append(data.ctrl.copy()))
    replay = []
    for _ in range(repeats):
        set_configuration(model, data, inverse_kinematics(geom, a), 0.0)
        t0 = time.perf_counter()
        for ctrl in ctrls:
            data.ctrl[:] = ctrl
            for _ in range(ex.substeps):
                mujoco.mj_step(model, data)
        replay.append((time.perf_counter() - t0) / (len(ctrls) * ex.substeps))
    print(f"  of which mj_step alone: {1e6 * np.median(replay):.1f} us per step")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--fit", action="store_true")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    model = load_robot()
    geom = geometry_from_model(model)
    gen = RuckigTrajectoryGenerator(limits_for_payload(0.1), geom, lumped_dynamics(model, geom))
    bench_planning(gen, 300 if args.quick else 2000, rng)
    bench_model(gen, 40 if args.quick else 150, rng, args.fit)
    bench_physics(3 if args.quick else 20)
    for payload in (0.1, 1.0, 3.0):
        r = run_cycle1(payload)
        print(
            f"Cycle 1 at {payload:g} kg: {r.cycle_time_s:.4f} s = {r.cycles_per_min:.1f}/min, "
            f"peak torque {100 * r.peak_torque_ratio:.0f} % of limit, tracking at pick/place "
            f"{r.tracking_error_pick_mm:.2f}/{r.tracking_error_place_mm:.2f} mm "
            f"(sortsim cycle --payload {payload:g})"
        )
    print(f"reproduce: {CMD}{' --quick' if args.quick else ''}")


if __name__ == "__main__":
    main()
