"""Real-time factor of the belt and its items alone (no robot), 60 items riding at once.

Scene `tests/models/belt_items.xml`: the cell's belt, rails and item pool with the cell's time
step and integrator. 60 items of every catalogue type (12 rows x 5 stripes) ride the belt at x1;
each that leaves at the discharge end is parked and a new one dropped at the infeed, so 60 stay
on the belt. Prints the median real-time factor of 5 runs of 30 s simulated time each, and
where a step's time goes (MuJoCo's own timers) with the mean contact count.

Run: `.venv/bin/python benchmarks/bench_belt.py [--quick]`
"""

from __future__ import annotations

import argparse
import math
import time

import mujoco
import numpy as np

from sim.cell.conveyor import Belt
from sim.cell.item_pool import ItemPool
from sim.flow.catalogue import load_catalogue
from sim.paths import REPO_ROOT

SCENE = REPO_ROOT / "tests" / "models" / "belt_items.xml"
N_ITEMS = 60
ROWS, STRIPES = 12, 5
TIMERS = (
    "mjTIMER_POS_KINEMATICS",
    "mjTIMER_POS_INERTIA",
    "mjTIMER_COL_BROAD",
    "mjTIMER_COL_NARROW",
    "mjTIMER_POS_MAKE",
    "mjTIMER_POS_PROJECT",
    "mjTIMER_VELOCITY",
    "mjTIMER_CONSTRAINT",
    "mjTIMER_ADVANCE",
)


def run(sim_seconds: float, seed: int) -> dict:
    """One run; returns the real-time factor, timer shares and mean contact count."""
    catalogue = load_catalogue()
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    data = mujoco.MjData(model)
    belt = Belt(model)
    belt.set_factor(1.0)
    pool = ItemPool(model, catalogue, belt)
    rng = np.random.default_rng(seed)
    geo = belt.geometry
    pitch = (geo.x_discharge - geo.x_infeed) / ROWS
    stripe_y = geo.y_centre + (np.arange(STRIPES) - (STRIPES - 1) / 2) * (2 * geo.y_half / STRIPES)
    next_id = 0

    def drop(x: float, stripe: int) -> None:
        nonlocal next_id
        k = int(rng.integers(len(catalogue.types)))
        item_type = catalogue.types[k]
        yaw = float(rng.uniform(-math.pi, math.pi))
        half_x, half_y = (float(h) for h in item_type.half_extents(yaw))
        if half_y > geo.y_half / STRIPES - 0.005 or half_x > pitch / 2 - 0.005:
            yaw = 0.0 if item_type.half_length < pitch / 2 - 0.005 else math.pi / 2
        colour = int(rng.choice(len(item_type.colour_probs), p=item_type.colour_probs))
        pool.spawn(data, next_id, k, x, float(stripe_y[stripe]), yaw, catalogue.rgba[colour])
        next_id += 1

    for row in range(ROWS):
        for stripe in range(STRIPES):
            drop(geo.x_infeed + pitch * (row + 0.5), stripe)
    stripe_of = {}
    for slot in pool.active_slots():
        stripe_of[int(pool.item_ids[slot])] = int(
            np.argmin(np.abs(stripe_y - data.qpos[pool.qpos_adr[slot] + 1]))
        )
    mujoco.mj_forward(model, data)
    for timer in data.timer:
        timer.duration, timer.number = 0.0, 0
    n_steps = int(round(sim_seconds / model.opt.timestep))
    contacts = 0
    start, cpu_start = time.perf_counter(), time.process_time()
    for _ in range(n_steps):
        mujoco.mj_step(model, data)
        contacts += data.ncon
        for item_id in pool.park_missed(data):
            drop(geo.x_infeed + pitch / 2, stripe_of.pop(item_id))
            stripe_of[next_id - 1] = stripe_of.get(next_id - 1, 0)
    wall = time.perf_counter() - start
    cpu = time.process_time() - cpu_start
    step_total = data.timer[mujoco.mjtTimer.mjTIMER_STEP].duration
    shares = {
        name[8:].lower(): data.timer[getattr(mujoco.mjtTimer, name)].duration / step_total
        for name in TIMERS
    }
    return {
        "rtf": sim_seconds / wall,
        "rtf_cpu": sim_seconds / cpu,
        "us_per_step": 1e6 * wall / n_steps,
        "shares": shares,
        "contacts": contacts / n_steps,
        "on_belt": len(pool.active_slots()),
        "timestep": model.opt.timestep,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 runs of 5 s instead of 30 s")
    args = parser.parse_args()
    sim_seconds = 5.0 if args.quick else 30.0
    runs = [run(sim_seconds, seed) for seed in range(5)]
    rtf = np.array([r["rtf"] for r in runs])
    best = runs[int(np.argsort(rtf)[len(rtf) // 2])]
    print(
        f"belt + items physics, {N_ITEMS} items on the belt at x1, "
        f"time step {best['timestep'] * 1e3:g} ms"
    )
    print(
        f"  real-time factor: median {np.median(rtf):.1f}x over 5 runs of {sim_seconds:g} s "
        f"(min {rtf.min():.1f}x, max {rtf.max():.1f}x), {best['us_per_step']:.0f} us per step"
    )
    rtf_cpu = np.array([r["rtf_cpu"] for r in runs])
    print(
        "  per CPU second of this process (the machine's other load aside): "
        f"median {np.median(rtf_cpu):.1f}x"
    )
    print(
        f"  contacts per step: {best['contacts']:.0f}; "
        f"items on the belt at the end: {best['on_belt']}"
    )
    shares = sorted(best["shares"].items(), key=lambda kv: -kv[1])
    print(
        "  step time (MuJoCo timers, median run): "
        + ", ".join(f"{k} {100 * v:.0f}%" for k, v in shares)
    )
    print(
        f"  reproduce: .venv/bin/python benchmarks/bench_belt.py{' --quick' if args.quick else ''}"
    )


if __name__ == "__main__":
    main()
