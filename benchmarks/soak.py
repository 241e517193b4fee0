"""Soak: many random episodes, each checked for what must never happen (`make soak`).

Random truth-perception episodes (items up to 12 per metre of belt, belt x1 / x1.2 / x1.5, the
decision managers qlearning, proximity, fifo and greedy, every riding mode, random seeds, flows
of 20-60 s; `sim.experiments.soak.draw_configs`) run in worker processes, one compiled cell each.
Every episode is checked for the accounting identities, MuJoCo warnings, a finite state and
items thrown off the belt (`sim.experiments.soak.soak_episode`). One line per episode, then a
summary; the exit status is 1 if any episode failed a check.

    python benchmarks/soak.py [--episodes 200] [--workers 2] [--seed 0] [--lines] [--shard K/N]
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim.experiments.soak import SoakResult, draw_configs, soak_episode  # noqa: E402


def _run(job: tuple[int, object]) -> tuple[int, SoakResult | str]:
    index, config = job
    try:
        return index, soak_episode(config)
    except Exception as exc:  # a crash is a failure to report, not a reason to stop the soak
        return index, f"{type(exc).__name__}: {exc}"


def main(argv: list[str] | None = None) -> int:
    """Run the soak; 0 when every episode passed every check, else 1."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200, help="random episodes (200)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (2)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the configs' draw (0)")
    parser.add_argument(
        "--lines", action="store_true", help="sorting lines of 2-4 robots on dense belts"
    )
    parser.add_argument(
        "--shard",
        default="0/1",
        help="K/N: only the episodes whose index is K modulo N (several machines or processes "
        "share one draw; 0/1: all)",
    )
    args = parser.parse_args(argv)
    try:
        shard, shards = (int(v) for v in args.shard.split("/"))
        assert 0 <= shard < shards
    except (ValueError, AssertionError):
        parser.error(f"--shard: K/N with 0 <= K < N (got {args.shard!r})")
    configs = draw_configs(args.episodes, args.seed, lines=args.lines)
    jobs = [(i, c) for i, c in enumerate(configs) if i % shards == shard]
    print(
        f"soak: {len(jobs)} random episodes (draw seed {args.seed}, shard {shard}/{shards}), "
        f"{args.workers} worker(s)",
        flush=True,
    )
    wall0 = time.perf_counter()
    results: dict[int, SoakResult] = {}
    crashed: dict[int, str] = {}
    context = multiprocessing.get_context("spawn")
    with context.Pool(max(1, args.workers)) as pool:
        for done, (index, result) in enumerate(pool.imap_unordered(_run, jobs), start=1):
            if isinstance(result, str):
                crashed[index] = result
                print(f"[{done:>3}/{len(jobs)}] #{index:<3} CRASH: {result}", flush=True)
                continue
            results[index] = result
            print(f"[{done:>3}/{len(jobs)}] #{index:<3} {result.line()}", flush=True)
    wall = time.perf_counter() - wall0
    runs = list(results.values())
    thrown = sum(r.row["thrown_off"] for r in runs)
    warnings = sum(r.row["mujoco_warnings"] for r in runs)
    identity = sum(r.identity_failures for r in runs)
    nonfinite = sum(r.nonfinite for r in runs)
    failed = sum(not r.ok for r in runs) + len(crashed)
    items = sum(r.row["entered"] for r in runs)
    picked = sum(r.row["picked"] for r in runs)
    cpu = sum(r.cpu_s for r in runs)
    sim_s = sum(r.row.get("sim_s", 0.0) for r in runs)
    peak = max((r.peak_loose_speed for r in runs), default=0.0)
    print(
        f"summary: episodes {len(jobs)}, items {items} (picked {picked}), thrown off {thrown}, "
        f"MuJoCo warnings {warnings}, identity failures {identity}, non-finite states "
        f"{nonfinite}, crashes {len(crashed)}, failed episodes {failed}; fastest loose item "
        f"{peak:.2f} m/s; CPU {cpu / 60:.1f} min, wall {wall / 60:.1f} min"
        + (f", {sim_s / 60:.1f} min simulated" if sim_s else "")
    )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
