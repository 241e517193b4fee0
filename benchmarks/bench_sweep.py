"""Throughput of a thesis sweep: table 4.5's episodes per CPU-hour, and per wall hour on the
machine's cores.

Runs `experiments/table_4_5.toml` (proximity and Q-learning at 80-400 items, x1, truth) with its
first N seeds (every grid point equally, so the mix of light and dense episodes is the full
table's) into a temporary folder, with the sweep's own local worker pool, and counts the CPU
time of this process and of every worker it started (the workers' CPU is read once they have
exited). The speed issue asks for at least 600 episodes per CPU-hour.

    python benchmarks/bench_sweep.py [--quick] [--seeds N] [--workers N]
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim.experiments import sweep_config  # noqa: E402
from sim.experiments import sweep_runner as sweep  # noqa: E402
from sim.paths import REPO_ROOT  # noqa: E402

CONFIG = REPO_ROOT / "experiments" / "table_4_5.toml"
TARGET_PER_CPU_HOUR = 600.0


def _cpu_s(who: int) -> float:
    usage = resource.getrusage(who)
    return usage.ru_utime + usage.ru_stime


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one seed per grid point")
    parser.add_argument("--seeds", type=int, default=2, help="seeds per grid point (of 10)")
    parser.add_argument("--workers", type=int, default=2, help="local worker processes")
    args = parser.parse_args()
    seeds = 1 if args.quick else args.seeds
    config = sweep_config.first_seeds(sweep_config.load(CONFIG), seeds)
    n = len(config.episodes)
    cpu0 = _cpu_s(resource.RUSAGE_SELF) + _cpu_s(resource.RUSAGE_CHILDREN)
    wall0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        rows = sweep.run_sweep(config, Path(out), workers=args.workers)
    wall = time.perf_counter() - wall0
    cpu = _cpu_s(resource.RUSAGE_SELF) + _cpu_s(resource.RUSAGE_CHILDREN) - cpu0
    simulated = sum(float(r["sim_s"]) for r in rows)
    print(
        f"table 4.5 sweep, first {seeds} seed(s) of 10 ({n} episodes, {simulated:.0f} s "
        f"simulated): {cpu:.0f} s CPU, {wall:.0f} s wall on {args.workers} worker(s); "
        f"{3600.0 * n / cpu:.0f} episodes per CPU-hour (the speed issue asks >= "
        f"{TARGET_PER_CPU_HOUR:.0f}), {3600.0 * n / wall:.0f} per wall hour, "
        f"{simulated / cpu:.1f}x real time by CPU   [python benchmarks/bench_sweep.py"
        f"{' --quick' if args.quick else f' --seeds {seeds}'} --workers {args.workers}]"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
