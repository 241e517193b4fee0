"""Today's code timed beside a reference commit, in one run, with the same outputs checked.

The shared machine's own speed moves 1.5-2.5x from day to day, so a speed figure means
something only as a ratio against a reference timed beside it. This script checks the reference
commit out in a git worktree (`runs/bench/ref-<commit>`, kept for the next run: a camera run's
first episode there fits the item classifier once), then runs each case as a whole command,
reference and today alternately (the order swapped every pair), and reports each side's CPU
time (the child process's user + system time) beside its wall time, medians of the pairs, and
today's factor over the reference. The outputs of the first pair are compared (episodes.csv and
picks.csv, wall-clock columns aside): a speed-up that changes a result is no speed-up.

    python benchmarks/against.py COMMIT [--pairs 3] [--only truth camera dense line env]

Cases (the speed issue's): the truth headline (x1, 100 items in 90 s, Q-learning, seeds 0..),
the camera headline (the same through the camera), 400 items in 191 s (truth), four robots with
a camera each (300 items in 90 s), and `sortsim/SortingCell-v0` (decisions per CPU second: the
environment's own loop, a fixed policy, `benchmarks/env_decisions.py`).
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BENCH_DIR = REPO / "runs" / "bench"
LINE_CONFIG = """robots = 4
items = 300
duration_s = 90
perception = "camera"

[camera]
per_robot = true

[cup]
diameter_m = 0.06  # the cup lines had by default before 50 mm: the same episodes on both sides
"""
ENV_SCRIPT = REPO / "benchmarks" / "env_decisions.py"


@dataclass(frozen=True)
class Case:
    """One command timed on both sides.

    Attributes:
        name: Its name on the command line (`--only`).
        title: What it is.
        args: `sortsim run` options (seed added per pair), or None for the environment.
    """

    name: str
    title: str
    args: tuple[str, ...] | None


CASES = (
    Case("truth", "truth headline (x1, 100 items, 90 s)", ("--perception", "truth")),
    Case("camera", "camera headline (x1, 100 items, 90 s)", ("--perception", "camera")),
    Case(
        "dense",
        "400 items over 191 s (truth)",
        ("--perception", "truth", "--items", "400", "--duration", "191"),
    ),
    Case("line", "four robots, a camera each, 300 items over 90 s", ("--config", "LINE")),
    Case("env", "sortsim/SortingCell-v0 decisions", None),
)


def reference_tree(commit: str) -> Path:
    """A worktree of `commit` under `runs/bench` (made once, reused)."""
    sha = subprocess.run(
        ["git", "rev-parse", "--verify", f"{commit}^{{commit}}"],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    tree = BENCH_DIR / f"ref-{sha[:12]}"
    if not (tree / "sim").is_dir():
        BENCH_DIR.mkdir(parents=True, exist_ok=True)
        subprocess.run(["git", "worktree", "prune"], cwd=REPO, check=True)
        subprocess.run(
            ["git", "worktree", "add", "--detach", str(tree), sha],
            cwd=REPO,
            check=True,
            capture_output=True,
        )
    return tree


def timed(cmd: list[str], cwd: Path) -> tuple[float, float, str]:
    """(CPU s, wall s, stdout) of `cmd` run in `cwd` as a child process."""
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), PYTHONPATH=str(cwd))
    env.setdefault("PYOPENGL_PLATFORM", "egl")
    wall0 = time.perf_counter()
    child = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, text=True)
    out = child.stdout.read()
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - wall0
    if child.returncode != 0:
        raise SystemExit(f"failed ({child.returncode}) in {cwd}: {' '.join(cmd)}")
    return usage.ru_utime + usage.ru_stime, wall, out


def command(case: Case, seed: int, out: Path, line_config: Path) -> list[str]:
    """The command of `case` for `seed`, writing into `out`."""
    if case.args is None:
        return [sys.executable, str(ENV_SCRIPT), "--seed", str(seed)]
    args = [str(line_config) if a == "LINE" else a for a in case.args]
    run = [sys.executable, "-m", "sim.cli", "run", "-q", *args]
    return [*run, "--seed", str(seed), "--out", str(out)]


def rows_without_wall(path: Path) -> list[dict]:
    """The rows of a CSV without its wall-clock columns and its code digest (a digest of the
    code that ran: it differs between two commits by design)."""
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    apart = ("real_time_factor", "code_digest")
    wall = {k for k in (rows[0] if rows else {}) if k.startswith("wall") or k in apart}
    return [{k: v for k, v in row.items() if k not in wall} for row in rows]


def same_outputs(a: Path, b: Path) -> str:
    """'same' when today's CSVs (`b`) agree with the reference's (`a`) on every column the
    reference writes (wall columns aside), naming the columns today adds; else what differs."""
    added: list[str] = []
    for name in ("episodes.csv", "picks.csv"):
        ra, rb = rows_without_wall(a / name), rows_without_wall(b / name)
        columns = list(ra[0]) if ra else []
        added += [k for k in (rb[0] if rb else {}) if k not in columns]
        if len(ra) != len(rb) or any(
            x != {k: y.get(k) for k in columns} for x, y in zip(ra, rb, strict=True)
        ):
            return f"DIFFERENT {name}"
    return "same" + (f" (columns added since: {', '.join(added)})" if added else "")


def run_case(case: Case, trees: dict[str, Path], pairs: int, scratch: Path) -> dict:
    """Time `case` on both sides, alternately; returns the figures."""
    line_config = scratch / "line.toml"
    line_config.write_text(LINE_CONFIG)
    times: dict[str, list[tuple[float, float, str]]] = {side: [] for side in trees}
    for pair in range(pairs):
        order = list(trees) if pair % 2 == 0 else list(trees)[::-1]
        for side in order:
            out = scratch / f"{case.name}-{side}-{pair}"
            cmd = command(case, pair, out, line_config)
            times[side].append(timed(cmd, trees[side]))
    figures = {
        side: (
            statistics.median(c for c, _, _ in runs),
            statistics.median(w for _, w, _ in runs),
        )
        for side, runs in times.items()
    }
    if case.args is None:  # the environment prints its decisions and their CPU time
        rates = {
            side: [float(o.split()[0]) / float(o.split()[1]) for _, _, o in runs]
            for side, runs in times.items()
        }
        figures = {side: (statistics.median(r),) for side, r in rates.items()}
        check = "(environment: no CSVs)"
    else:
        check = same_outputs(scratch / f"{case.name}-reference-0", scratch / f"{case.name}-today-0")
    return {"figures": figures, "check": check}


def report(case: Case, result: dict, commit: str, pairs: int) -> str:
    """The case's lines for the terminal."""
    f = result["figures"]
    if case.args is None:
        ref, now = f["reference"][0], f["today"][0]
        return (
            f"{case.title}: {now:.1f} decisions per CPU s today, {ref:.1f} at {commit} "
            f"-> {now / ref:.2f}x (medians of {pairs} pairs)"
        )
    (ref_cpu, ref_wall), (cpu, wall) = f["reference"], f["today"]
    return (
        f"{case.title}: CPU {cpu:.1f} s today, {ref_cpu:.1f} s at {commit} -> "
        f"{ref_cpu / cpu:.2f}x; wall {wall:.1f} s against {ref_wall:.1f} s -> "
        f"{ref_wall / wall:.2f}x (medians of {pairs} pairs); outputs: {result['check']}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("commit", help="the reference commit (a hash, tag or branch)")
    parser.add_argument("--pairs", type=int, default=3, help="reference/today pairs (>= 1)")
    names = [c.name for c in CASES]
    parser.add_argument("--only", nargs="+", choices=names, default=names, metavar="CASE")
    args = parser.parse_args(argv)
    if args.pairs < 1:
        parser.error("--pairs: at least 1")
    trees = {"reference": reference_tree(args.commit), "today": REPO}
    print(
        f"today's code against {args.commit} ({trees['reference']}), CPU time of each whole "
        f"command  [python benchmarks/against.py {args.commit} --pairs {args.pairs}]",
        flush=True,
    )
    with tempfile.TemporaryDirectory(prefix="sortsim-bench-") as tmp:
        for case in CASES:
            if case.name in args.only:
                result = run_case(case, trees, args.pairs, Path(tmp))
                print(report(case, result, args.commit, args.pairs), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
