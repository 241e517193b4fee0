"""A shift's memory and speed: one long truth episode, its peak memory at each hour.

Runs one episode of `--hours` simulated hours (truth perception, `--items-per-m` items per metre
of belt arriving over the whole shift, the run ended at the shift's end: `horizon_s` =
`duration_s`) in this process, its picks streamed to `<out>/picks.csv` as `sortsim run` streams
them. Every `--every-min` simulated minutes it prints the process's resident memory (now, and
the peak of the samples taken about once per simulated second since the start), the peak of
`resource.getrusage` (`ru_maxrss`), the memory in transparent huge pages, the wall and CPU time
so far and wall / simulated time.
At the end: the peak memory at the last full hour against that at 1 h (the shift's memory is
flat when it is within 10 %), and the wall time per simulated hour of the first hour and of the
whole run (proportional when they agree).

    python benchmarks/long_run.py [--hours 8] [--items-per-m 1.5] [--seed 0] [--out DIR]
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
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim import config as episode_config  # noqa: E402
from sim.episode.runner import run_episode  # noqa: E402
from sim.results.outputs import PickStream  # noqa: E402

PAGE_KB = os.sysconf("SC_PAGE_SIZE") / 1024.0
FLAT_WITHIN = 0.10
"""The peak memory at the shift's end may exceed that at 1 h by this share at most."""


def rss_mb() -> float:
    """This process's resident memory now [MB] (/proc/self/statm)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * PAGE_KB / 1024.0


def huge_pages_mb() -> float:
    """This process's anonymous memory in transparent huge pages [MB] (0 where unknown): the
    kernel may back a region with 2 MB pages (numpy asks for them on large arrays), each
    counted whole in the resident memory however little of it is used."""
    try:
        with open("/proc/self/smaps_rollup") as f:
            for line in f:
                if line.startswith("AnonHugePages:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return 0.0


def max_rss_mb() -> float:
    """The peak resident memory of this process since it started [MB] (Linux: ru_maxrss kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class Sampler:
    """The episode's progress callback: samples the memory about once per simulated second and
    prints one line every `every_s` simulated seconds [s]."""

    def __init__(self, t_end: float, every_s: float):
        self.t_end, self.every_s = t_end, every_s
        self.next_s = every_s
        self.peak_mb = rss_mb()
        self.wall0, self.cpu0 = time.perf_counter(), time.process_time()
        self.points: list[dict] = []

    def __call__(self, fraction: float, text: str) -> None:
        t = float(text.split()[1])  # the status line: "t <s> s ..."
        self.peak_mb = max(self.peak_mb, rss_mb())
        while t >= self.next_s - 1e-6:
            self.point(self.next_s)
            self.next_s += self.every_s

    def point(self, t: float) -> None:
        wall, cpu = time.perf_counter() - self.wall0, time.process_time() - self.cpu0
        point = {"t": t, "rss": rss_mb(), "peak": self.peak_mb, "maxrss": max_rss_mb()}
        point["huge"] = huge_pages_mb()
        point |= {"wall": wall, "cpu": cpu}
        self.points.append(point)
        print(
            f"sim {t / 3600:5.2f} h  rss {point['rss']:7.1f} MB  peak {point['peak']:7.1f} MB  "
            f"ru_maxrss {point['maxrss']:7.1f} MB  huge pages {point['huge']:5.1f} MB  "
            f"wall {wall:7.1f} s  cpu {cpu:7.1f} s  "
            f"wall/sim {wall / t:.4f}",
            flush=True,
        )


def hour_point(points: list[dict], hours: float) -> dict | None:
    """The sample taken at `hours` simulated hours (None: not reached)."""
    return next((p for p in points if abs(p["t"] - 3600.0 * hours) < 1e-6), None)


def report(points: list[dict]) -> int:
    """Print the comparison of the last full hour with the first; 1 when memory grew by more
    than `FLAT_WITHIN`."""
    first = hour_point(points, 1)
    hours = [p for p in points if abs(p["t"] / 3600.0 - round(p["t"] / 3600.0)) < 1e-9]
    if first is None or not hours:
        print("the run did not reach 1 simulated hour")
        return 1
    last = hours[-1]
    growth = last["peak"] / first["peak"] - 1.0
    print(
        f"peak memory: {first['peak']:.1f} MB at 1 h, {last['peak']:.1f} MB at "
        f"{last['t'] / 3600:g} h ({100 * growth:+.1f} %; ru_maxrss {first['maxrss']:.1f} -> "
        f"{last['maxrss']:.1f} MB)"
    )
    per_hour_first, per_hour = first["wall"], last["wall"] / (last["t"] / 3600.0)
    print(
        f"wall per simulated hour: {per_hour_first:.1f} s in the first hour, {per_hour:.1f} s "
        f"over {last['t'] / 3600:g} h (factor {per_hour / per_hour_first:.3f}); wall/sim "
        f"{last['wall'] / last['t']:.4f}, CPU {last['cpu']:.1f} s"
    )
    return 0 if growth <= FLAT_WITHIN else 1


def main(argv: list[str] | None = None) -> int:
    """Run the shift and print its memory and time; 1 when the memory was not flat."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=8.0, help="simulated hours (8)")
    parser.add_argument("--items-per-m", type=float, default=1.5, help="flow density (1.5)")
    parser.add_argument("--seed", type=int, default=0, help="the episode's seed (0)")
    parser.add_argument("--every-min", type=float, default=30.0, help="minutes per line (30)")
    parser.add_argument("--out", type=Path, default=None, help="folder of picks.csv (a temp)")
    args = parser.parse_args(argv)
    if not 1.0 <= args.hours <= 10.0:
        parser.error(f"--hours: 1..10 (got {args.hours})")
    end_s = 3600.0 * args.hours
    config = episode_config.load(
        None,
        perception="truth",
        items_per_m=args.items_per_m,
        duration_s=end_s,
        horizon_s=end_s,
        seed=args.seed,
    )
    out = args.out or Path(tempfile.mkdtemp(prefix="long-run-"))
    out.mkdir(parents=True, exist_ok=True)
    print(
        f"long run: {config.items} items over {end_s:g} s ({args.items_per_m:g} items/m, truth, "
        f"seed {args.seed}); picks into {out / 'picks.csv'}",
        flush=True,
    )
    sampler = Sampler(end_s, 60.0 * args.every_min)
    with PickStream(out / "picks.csv") as picks:
        result = run_episode(config, progress=sampler, picks=picks)
        picks.land()
    if not sampler.points or sampler.points[-1]["t"] < end_s:  # the shift's end: its last line
        sampler.peak_mb = max(sampler.peak_mb, rss_mb())
        sampler.point(end_s)
    row = result.episode_row
    print(
        f"entered {row['entered']}, picked {row['picked']}, missed {row['missed']}, dropped "
        f"{row['dropped']}, left on the belt {row['left_on_belt']}; {picks.rows} picks written",
        flush=True,
    )
    return report(sampler.points)


if __name__ == "__main__":
    sys.exit(main())
