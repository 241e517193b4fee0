"""`sortsim bench`: runs every `benchmarks/bench_*.py` script and prints its figures.

Each script measures one subsystem and prints medians/ratios with the command that reproduces
them; this command only runs them in turn (each in its own process, so one subsystem's imports
and caches do not colour another's timings).
"""

from __future__ import annotations

import argparse
import subprocess
import sys

from sim.paths import REPO_ROOT

BENCH_DIR = REPO_ROOT / "benchmarks"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim bench`."""
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    parser.add_argument("--only", default=None, help="run only bench_<ONLY>.py")


def main(args: argparse.Namespace) -> int:
    """Run the benchmark scripts; exit 1 if any of them failed."""
    scripts = sorted(BENCH_DIR.glob("bench_*.py"))
    if args.only is not None:
        names = [s.stem.removeprefix("bench_") for s in scripts]
        if args.only not in names:
            from sim.errors import InvalidInput

            raise InvalidInput("--only", "one of " + ", ".join(names), args.only)
        scripts = [s for s in scripts if s.stem == f"bench_{args.only}"]
    failed = []
    for script in scripts:
        print(f"== {script.stem}  (python {script.relative_to(REPO_ROOT)})", flush=True)
        cmd = [sys.executable, str(script)] + (["--quick"] if args.quick else [])
        if subprocess.run(cmd, cwd=REPO_ROOT).returncode != 0:
            failed.append(script.stem)
    if failed:
        print("failed: " + ", ".join(failed), file=sys.stderr)
        return 1
    return 0
