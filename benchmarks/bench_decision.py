"""Decision managers: latency per decision with 30 items in view, and profit against the
oracle's bound on seeded random belts (the cycle-time model is the ruckig-fitted one).

The profit figures are on the held-out belts (`evaluation.HELD_OUT_SEEDS`, seeds 0-199); the
planners' parameters were chosen on `evaluation.TUNING_SEEDS` (1000-1199, `--tuning`).

Run: `.venv/bin/python benchmarks/bench_decision.py [--quick] [--tuning]`
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from planner.decision.evaluation import (
    HELD_OUT_SEEDS,
    TUNING_SEEDS,
    extreme_value_picks,
    objective_variants,
    oracle_fractions,
)
from planner.decision.interface import RobotState, TrackedItem
from planner.decision.registry import PLANNERS, make_planner
from sim.episode.decision_view import cell_context

CMD = ".venv/bin/python benchmarks/bench_decision.py"


def random_view(rng, n_items, t):
    """`n_items` tracked items across the camera-to-window stretch, HMM-like probabilities."""
    items = []
    for k in range(n_items):
        probs = rng.dirichlet([0.3, 1.0, 1.0, 1.0])
        probs[1 + rng.integers(3)] += 2.0  # one material clearly most probable
        items.append(
            TrackedItem(
                k, rng.uniform(-1.5, 0.55), rng.uniform(-0.35, 0.35), tuple(probs / probs.sum())
            )
        )
    return items


def latency(context_for, n_items, decisions):
    """Median and p99 [us] of one `choose` call per planner with `n_items` in view: wall time
    and this thread's CPU time (the latter less affected by other processes on the core).
    Each decision starts from `reset()`: qlearning learns its batch at every one."""
    ctx = context_for(0.185)
    out = {}
    for name in PLANNERS:
        rng = np.random.default_rng(0)
        planner = make_planner(name)
        wall, cpu = [], []
        for _ in range(decisions if name != "oracle" else max(decisions // 10, 5)):
            items = random_view(rng, n_items, 0.0)
            robot = RobotState(ctx.bins[rng.integers(3)], 0.0)
            planner.reset()
            tic, tic_cpu = time.perf_counter_ns(), time.thread_time_ns()
            planner.choose(items, robot, ctx)
            cpu.append(time.thread_time_ns() - tic_cpu)
            wall.append(time.perf_counter_ns() - tic)
        w, c = 1e-3 * np.array(wall), 1e-3 * np.array(cpu)
        out[name] = tuple(float(x) for x in (np.median(w), np.percentile(w, 99)))
        out[name] += tuple(float(x) for x in (np.median(c), np.percentile(c, 99), w.size))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer decisions and belts")
    parser.add_argument("--tuning", action="store_true", help="the tuning belts, not held-out")
    args = parser.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core
    context_for = cell_context
    n_dec = 200 if args.quick else 2000
    print(f"decision latency, 30 items in view, one core ({CMD}{' --quick' if args.quick else ''})")
    for name, (med, p99, cmed, cp99, n) in latency(context_for, 30, n_dec).items():
        print(
            f"  {name:10s} wall median {med:9.1f} us p99 {p99:9.1f} us | "
            f"cpu median {cmed:9.1f} us p99 {cp99:9.1f} us  (n={int(n)})"
        )
    print(f"  load average while measuring: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    n_belts = 40 if args.quick else 200
    seeds = (TUNING_SEEDS if args.tuning else HELD_OUT_SEEDS)[:n_belts]
    which = "tuning" if args.tuning else "held-out"
    tic = time.perf_counter()
    result = oracle_fractions(context_for, seeds)
    print(
        f"profit / oracle bound on {n_belts} {which} busy belts, seeds {seeds.start}-"
        f"{seeds.stop - 1} (planner.decision.evaluation.short_belt), "
        f"{time.perf_counter() - tic:.0f} s"
    )
    print(f"  bound: {result.bound_used()}")
    for name, (mean, low, total) in result.summary().items():
        print(f"  {name:10s} mean {mean:.3f}  min {low:.3f}  profit {total:.2f} EUR")
    print(f"  oracle     bound profit {result.bound.sum():.2f} EUR")
    light = oracle_fractions(context_for, seeds, front_x=-0.7)
    print("the same belts arriving from upstream of the window (front_x = -0.7 m): light load")
    print(f"  bound: {light.bound_used()}")
    for name, (mean, low, total) in light.summary().items():
        print(f"  {name:10s} mean {mean:.3f}  min {low:.3f}  profit {total:.2f} EUR")
    print(f"  oracle     bound profit {light.bound.sum():.2f} EUR")
    seeds = range(3 if args.quick else 10)
    print(f"objective variants (section 4.1.3), {len(seeds)} belts of 118 items in 45 s")
    for planner in ("qlearning", "rollout"):
        for factor in (1.0, 1.2):
            variants = objective_variants(context_for, seeds, factor, planner=planner)
            for objective, (share, profit) in variants.items():
                print(
                    f"  x{factor:g} {planner:9s} {objective:4s} picked {share:.3f} of the items, "
                    f"profit {profit:.2f} EUR per belt"
                )
    print(f"extreme values (table 4.3): picks per class, {len(seeds)} belts of 118 items in 45 s")
    for planner in ("qlearning", "rollout", "lookahead", "greedy", "proximity"):
        for variant, counts in extreme_value_picks(context_for, planner, seeds).items():
            share = counts / max(counts.sum(), 1)
            print(
                f"  {planner:10s} {variant:14s} paper {counts[0]:4d} plastic {counts[1]:4d} "
                f"aluminium {counts[2]:4d}  shares {share[0]:.2f}/{share[1]:.2f}/{share[2]:.2f}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
