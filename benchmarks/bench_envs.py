"""Speed of the Gymnasium environments: PickOrder-v0 steps/s and SortingCell-v0 decisions/s.

Both by CPU time (this process) beside wall time, medians over runs; the policy is the first
masked slot (FIFO), so every run makes the same decisions.

    python benchmarks/bench_envs.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from sim.envs.pick_order import PickOrderEnv  # noqa: E402
from sim.envs.sorting_cell import SortingCellEnv  # noqa: E402


def _steps(env, seed: int, max_steps: int) -> tuple[int, float, float]:
    """(steps, CPU s, wall s) of a FIFO rollout from `seed`, resetting as episodes end."""
    obs, info = env.reset(seed=seed)
    n, c0, w0 = 0, time.process_time(), time.perf_counter()
    while n < max_steps:
        action = int(np.flatnonzero(info["action_mask"])[0])
        obs, _, done, _, info = env.step(action)
        n += 1
        if done:
            seed += 1
            obs, info = env.reset(seed=seed)
    return n, time.process_time() - c0, time.perf_counter() - w0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    runs = 3
    env = PickOrderEnv()
    rates = [_steps(env, 100 * r, 2000 if args.quick else 10000) for r in range(runs)]
    cpu = statistics.median(n / c for n, c, _ in rates)
    wall = statistics.median(n / w for n, _, w in rates)
    print(
        f"sortsim/PickOrder-v0: {cpu:.0f} steps/s by CPU time, {wall:.0f} by wall time "
        f"(median of {runs})  [python benchmarks/bench_envs.py]"
    )
    cell_env = SortingCellEnv(items=100, duration_s=90.0)
    decisions = 100 if args.quick else 400
    rates = [_steps(cell_env, r, decisions) for r in range(runs)]
    cell_env.close()
    cpu = statistics.median(n / c for n, c, _ in rates)
    wall = statistics.median(n / w for n, _, w in rates)
    print(
        f"sortsim/SortingCell-v0 (truth, x1, 100 items): {cpu:.1f} decisions/s by CPU time, "
        f"{wall:.1f} by wall time (median of {runs})  [python benchmarks/bench_envs.py]"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
