"""`sortsim reproduce`: the thesis's chapter 4, every table and figure, from the current code.

    sortsim reproduce --list                       # every table and figure, what each runs
    sortsim reproduce --quick --workers 2          # all of it, one or two seeds a grid point
    sortsim reproduce --only table_4_1 --quick     # one piece (repeatable: --only a b)
    sortsim reproduce                              # the thesis's seed counts

The sweeps run into `--out` (default runs/reproduce), one folder each, resumable as `sortsim
sweep`'s (rerunning skips the episodes already there; a full run after a quick one adds the
seeds the quick one left out). A folder whose episodes ran on other code (another code digest)
is refused in one line before any work, unless `--mix-code`; each block's first line names the
commit and code digest its episodes ran on, and says MIXED CODE when they ran on several.
Each piece is printed, written to `<out>/<name>.md`, and put between its markers in `--docs`
(default docs/results.md; its figures in docs/results/); `--no-docs` leaves the docs alone
(figures in `<out>/figures/`). The logic is in `sim.experiments.thesis.reproduce`.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

MAX_WORKERS = 256
"""Most local worker processes a sweep may start."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim reproduce`."""
    parser.add_argument("--list", action="store_true", help="name every table and figure, and exit")
    parser.add_argument(
        "--only", nargs="+", default=[], metavar="NAME", help="these pieces only (see --list)"
    )
    parser.add_argument(
        "--quick", action="store_true", help="one or two seeds a grid point (the thesis's: 4-10)"
    )
    parser.add_argument(
        "--out", type=Path, default=None, help="the sweeps' folders (default runs/reproduce)"
    )
    parser.add_argument(
        "--workers", type=int, default=None, help="local worker processes (default: CPU count)"
    )
    parser.add_argument(
        "--ray",
        default=None,
        metavar="ADDRESS",
        help="run the episodes on a Ray cluster ('local' starts one; needs sortsim[cluster])",
    )
    parser.add_argument(
        "--mix-code",
        action="store_true",
        help="add to sweep folders whose episodes ran on other code (another code digest); "
        "refused without it, and the blocks then say they mix",
    )
    docs = parser.add_mutually_exclusive_group()
    docs.add_argument(
        "--docs", type=Path, default=None, help="the markdown file to fill (docs/results.md)"
    )
    docs.add_argument("--no-docs", action="store_true", help="leave the docs as they are")


def main(args: argparse.Namespace) -> int:
    """List, or run the chosen pieces and fill the docs."""
    from sim.errors import InvalidInput
    from sim.experiments.thesis import reproduce

    if args.list:
        print(reproduce.list_text(args.quick))
        return 0
    if args.workers is not None and not 1 <= args.workers <= MAX_WORKERS:
        raise InvalidInput("--workers", f"an integer 1..{MAX_WORKERS}", args.workers)
    if args.ray is not None:
        from sim.experiments.sweep_runner import require_ray

        require_ray(args.ray)
    out = reproduce.DEFAULT_OUT if args.out is None else args.out
    docs = None if args.no_docs else (args.docs or reproduce.DOCS_FILE)
    if docs is not None and not Path(docs).is_file():
        raise InvalidInput("--docs", "an existing markdown file with reproduce markers", docs)
    figures: Path | None = None
    link = ""
    if docs is not None:
        figures = Path(docs).parent / "results"
        link = os.path.relpath(figures, Path(docs).parent) + "/"
    run = reproduce.Run(
        out,
        args.quick,
        args.workers,
        args.ray,
        figures=figures,
        link=link,
        mix_code=args.mix_code,
    )
    tic = time.perf_counter()
    made = reproduce.reproduce(args.only, run, docs)
    print(
        f"\n{len(made)} pieces in {time.perf_counter() - tic:.0f} s; sweeps in {out}"
        + ("" if docs is None else f"; written into {docs}"),
        file=sys.stderr,
    )
    return 0
