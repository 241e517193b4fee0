"""Decisions of `sortsim/SortingCell-v0` (truth, x1, 100 items in 90 s) per CPU second.

Runs `--decisions` decisions (the first masked slot each time, so every run makes the same
ones) from `--seed`, resetting with the next seed as episodes end, and prints the decisions
made and the CPU time of that loop (this process) [s]. `benchmarks/against.py` runs it in a
reference commit's tree and in today's.

    python benchmarks/env_decisions.py [--seed 0] [--decisions 400]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

from sim.envs.sorting_cell import SortingCellEnv  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--decisions", type=int, default=400)
    args = parser.parse_args()
    env = SortingCellEnv(items=100, duration_s=90.0)
    seed = args.seed * 1000
    _, info = env.reset(seed=seed)
    n, cpu0 = 0, time.process_time()
    while n < args.decisions:
        action = int(np.flatnonzero(info["action_mask"])[0])
        _, _, done, _, info = env.step(action)
        n += 1
        if done:
            seed += 1
            _, info = env.reset(seed=seed)
    cpu = time.process_time() - cpu0
    env.close()
    print(f"{n} {cpu:.6f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
