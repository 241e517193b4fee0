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
    parser.add_argument(
        "--only", default=None, help="run only bench_<ONLY>.py (against: only the comparison)"
    )
    parser.add_argument(
        "--against",
        default=None,
        metavar="COMMIT",
        help="then time today's code beside COMMIT's in one run, alternately, and print "
        "today's factors (benchmarks/against.py: the headlines, 400 items, a line of four "
        "cameras, SortingCell-v0; CPU time, medians of --pairs pairs; the outputs compared)",
    )
    parser.add_argument(
        "--pairs", type=int, default=3, help="reference/today pairs with --against (default 3)"
    )


def _refuse_bad_reference(args: argparse.Namespace) -> None:
    """`--against` names a commit of this checkout and `--pairs` is at least 1, or refused in
    one line before anything runs."""
    from sim.errors import InvalidInput

    if args.pairs < 1:
        raise InvalidInput("--pairs", "a whole number of pairs >= 1", args.pairs)
    found = subprocess.run(
        ["git", "rev-parse", "--verify", "--quiet", f"{args.against}^{{commit}}"],
        cwd=REPO_ROOT,
        capture_output=True,
    )
    if found.returncode != 0:
        raise InvalidInput("--against", "a commit of this git checkout", args.against)


def main(args: argparse.Namespace) -> int:
    """Run the benchmark scripts (and the comparison with `--against`); exit 1 if any
    failed."""
    scripts = sorted(BENCH_DIR.glob("bench_*.py"))
    if args.only is not None:
        names = [s.stem.removeprefix("bench_") for s in scripts]
        if args.only not in names and not (args.only == "against" and args.against):
            from sim.errors import InvalidInput

            allowed = ", ".join(names) + " (against, with --against)"
            raise InvalidInput("--only", "one of " + allowed, args.only)
        scripts = [s for s in scripts if s.stem == f"bench_{args.only}"]
    if args.against is not None:
        _refuse_bad_reference(args)
    failed = []
    for script in scripts:
        print(f"== {script.stem}  (python {script.relative_to(REPO_ROOT)})", flush=True)
        cmd = [sys.executable, str(script)] + (["--quick"] if args.quick else [])
        if subprocess.run(cmd, cwd=REPO_ROOT).returncode != 0:
            failed.append(script.stem)
    if args.against is not None:
        script = BENCH_DIR / "against.py"
        print(f"== against {args.against}  (python {script.relative_to(REPO_ROOT)})", flush=True)
        cmd = [sys.executable, str(script), args.against, "--pairs", str(args.pairs)]
        if subprocess.run(cmd, cwd=REPO_ROOT).returncode != 0:
            failed.append("against")
    if failed:
        print("failed: " + ", ".join(failed), file=sys.stderr)
        return 1
    return 0
