"""Where one episode's time goes, stage by stage, and what a physics step costs against the
robot alone.

Runs one episode in this process with the stages timed (wall time, `time.perf_counter`, around
the functions that make each stage; on a quiet machine wall time is CPU time, and the process's
CPU time is printed beside): start-up (imports, the cell's model, the episode's parts, up to
the first step), physics (`mujoco.mj_step`), the work of each busy step around it (the chunks'
set-points, actuator log, cups: `sim.episode.chunks`), the item checks every 20 ms, pick
planning, decisions, rendering (`mjv_updateScene`, `mjr_render`, `mjr_readPixels`), the rest of
perception, the visibility monitor, and what is left (the loop, idle blocks, events). Then
MuJoCo's own timers (`data.timer`) for a step of the robot alone playing ABB's Cycle 1, of the
cell playing the same with no item, and of the episode's busy and idle steps.

    python benchmarks/stages.py [--perception truth|camera] [--seed 0] [--items 100]
        [--duration 90] [--robots 1] [--per-robot-camera]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

START_WALL, START_CPU = time.perf_counter(), time.process_time()
os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

REAL_STEP = mujoco.mj_step

TIMERS = ("STEP", "POSITION", "COLLISION", "CONSTRAINT", "ADVANCE")
_SPENT: dict[str, float] = {}
_FIRST_STEP: list[float] = []
_STEPS = {"busy": [0, 0.0], "idle": [0, 0.0]}  # steps and their mj_step wall time [s]


def _timed(owner, name: str, stage: str) -> None:
    """Replace `owner.name` by a wrapper adding its wall time to `stage`."""
    fn = getattr(owner, name)

    def wrapper(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            _SPENT[stage] = _SPENT.get(stage, 0.0) + time.perf_counter() - t0

    setattr(owner, name, wrapper)


def _instrument() -> None:
    """Wrap the functions that make each stage (before the episode's modules bind them)."""
    real_step = mujoco.mj_step

    def step(model, data, nstep=1):
        if not _FIRST_STEP:
            _FIRST_STEP.append(time.perf_counter())
        t0 = time.perf_counter()
        real_step(model, data, nstep=nstep)
        kind = _STEPS["busy" if nstep == 1 else "idle"]  # a chunk's steps are one at a time
        kind[0] += nstep
        kind[1] += time.perf_counter() - t0

    mujoco.mj_step = step
    for name in ("mjv_updateScene", "mjr_render", "mjr_readPixels"):
        _timed(mujoco, name, "rendering")
    from sim.episode import chunks, item_checks

    _timed(chunks, "step_busy", "busy steps")
    _timed(item_checks, "run_checks", "item checks")


def stage_table(timings: dict, total: float) -> list[tuple[str, float]]:
    """(stage, seconds) of the episode, the rest last."""
    physics = _STEPS["busy"][1] + _STEPS["idle"][1]
    busy = _SPENT.get("busy steps", 0.0)
    rendering = _SPENT.get("rendering", 0.0)
    rows = [
        ("start-up (imports, model, parts)", _FIRST_STEP[0] - START_WALL),
        ("physics (mj_step)", physics),
        ("busy steps' own work (set-points, log, cups)", max(busy - _STEPS["busy"][1], 0.0)),
        ("item checks (every 20 ms)", _SPENT.get("item checks", 0.0)),
        ("pick planning", timings.get("planning", 0.0)),
        ("decisions", timings.get("decision", 0.0)),
        ("rendering (scene, render, read)", rendering),
        ("perception (the rest)", max(timings.get("perception", 0.0) - rendering, 0.0)),
        ("visibility monitor", timings.get("visibility", 0.0)),
    ]
    rows.append(("the rest (loop, idle blocks, events)", total - sum(t for _, t in rows)))
    return rows


def _timer_means(data: mujoco.MjData, steps: int) -> dict[str, float]:
    """MuJoCo's timers per step [us], reset after reading."""
    out = {}
    for name in TIMERS:
        kind = "POS_COLLISION" if name == "COLLISION" else name
        timer = data.timer[getattr(mujoco.mjtTimer, f"mjTIMER_{kind}")]
        out[name] = timer.duration / max(steps, 1) * 1e6
    for t in data.timer:
        t.duration, t.number = 0.0, 0
    return out


def cycle_on(model: mujoco.MjModel, data: mujoco.MjData) -> dict[str, float]:
    """MuJoCo's timers per step of ABB's Cycle 1 played on the robot of `model` [us]."""
    from planner.motion.kinematics import inverse_kinematics
    from planner.motion.limits import limits_for_payload
    from planner.motion.pick_cycle import plan_cycle1
    from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
    from sim.cell.executor import TrajectoryExecutor, lumped_dynamics
    from sim.cell.robot import geometry_from_model, set_configuration
    from sim.evaluation.cycle1 import CYCLE1_START

    geometry = geometry_from_model(model)
    generator = RuckigTrajectoryGenerator(
        limits_for_payload(0.0), geometry, lumped_dynamics(model, geometry)
    )
    start = np.array(CYCLE1_START)
    chain = plan_cycle1(start, generator)
    set_configuration(model, data, inverse_kinematics(geometry, start), 0.0)
    mujoco.mj_forward(model, data)
    _timer_means(data, 1)
    log = TrajectoryExecutor(model, data, geometry=geometry).execute(chain, hold=0.05)
    return _timer_means(data, len(log.time))


def step_costs(episode_model, busy: tuple[int, float], idle: tuple[int, float]) -> list[str]:
    """Lines: a step's cost by MuJoCo's timers, the robot alone against the cell."""
    from sim.cell.cell import Cell
    from sim.evaluation.cycle1 import model_with_payload

    mujoco.set_mjcb_time(time.perf_counter)
    alone = model_with_payload(0.0)
    cell = Cell()
    cell.reset(0.185)
    rows = [
        ("robot alone, Cycle 1", cycle_on(alone, mujoco.MjData(alone))),
        (f"cell ({cell.pool.size} pool bodies, no item), Cycle 1", cycle_on(cell.model, cell.data)),
    ]
    mujoco.set_mjcb_time(None)
    lines = ["MuJoCo's timers per step [us] (" + ", ".join(n.lower() for n in TIMERS) + "):"]
    for label, t in rows:
        lines.append(f"  {label}: " + ", ".join(f"{t[n]:.1f}" for n in TIMERS))
    lines.append(
        f"  the episode ({episode_model.nv} dofs): {busy[0]} busy steps at {busy[1]:.1f} us, "
        f"{idle[0]} idle steps at {idle[1]:.1f} us (wall time of mj_step, the timers off)"
    )
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--perception", default="truth", choices=("truth", "camera"))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--items", type=int, default=100)
    parser.add_argument("--duration", type=float, default=90.0)
    parser.add_argument("--robots", type=int, default=1)
    parser.add_argument("--per-robot-camera", action="store_true")
    args = parser.parse_args()
    _instrument()
    from sim import config as episode_config
    from sim.episode.runner import run_episode

    overrides = dict(seed=args.seed, items=args.items, duration_s=args.duration)
    overrides |= dict(perception=args.perception, robots=args.robots)
    config = episode_config.load(None, **overrides)
    if args.per_robot_camera:
        config = config.replace(camera=episode_config.Camera(per_robot=True))
    result = run_episode(config)
    total = time.perf_counter() - START_WALL
    cpu = time.process_time() - START_CPU
    sim_s = result.episode_row["sim_s"]
    print(
        f"{args.perception}, seed {args.seed}, {args.items} items over {args.duration:g} s, "
        f"{args.robots} robot(s): {sim_s:.1f} s simulated in {total:.1f} s wall, {cpu:.1f} s "
        f"CPU ({sim_s / cpu:.1f}x real time by CPU), the whole process"
    )
    if total > 1.1 * cpu:
        print(f"  (wall time {total / cpu:.2f}x the CPU time: other work shared the cores, so the")
        print(
            "  stages below, timed by the wall clock, are not this episode's alone; run it again)"
        )
    for stage, seconds in stage_table(result.timings, total):
        print(f"  {stage:46s} {seconds:6.2f} s  {100 * seconds / total:5.1f} %")
    from sim.episode.runner import config_cell

    (busy, busy_s), (idle, idle_s) = _STEPS["busy"], _STEPS["idle"]
    mujoco.mj_step = REAL_STEP
    lines = step_costs(
        config_cell(config, sized=True).model,
        (busy, busy_s / max(busy, 1) * 1e6),
        (idle, idle_s / max(idle, 1) * 1e6),
    )
    print("\n".join(lines))
    command = " ".join(["python benchmarks/stages.py", *sys.argv[1:]])
    print(f"reproduce: {command}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
