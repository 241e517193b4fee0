"""`sortsim report`: means, 95 % intervals, paired comparisons of the planners, figures and
one HTML page of run or sweep folders (`sim.experiments.report`)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim report`."""
    parser.add_argument("dirs", nargs="+", type=Path, metavar="DIR", help="run or sweep folders")
    parser.add_argument(
        "--out", type=Path, default=None, help="where to write the report (default: DIR/report)"
    )
    parser.add_argument(
        "--baseline",
        default=None,
        metavar="NAME",
        help="the planner every other is compared with, seed by seed (a planner of the "
        "episodes, by name or short label; default: the best of each grid point by mean profit)",
    )


def main(args: argparse.Namespace) -> int:
    """Write the report and list its files."""
    from sim.experiments.report import check_baseline, group_key, read_folders, write_report
    from sim.experiments.reporting.groups import grouping_text
    from sim.results.outputs import check_output_dir

    out = args.out if args.out is not None else args.dirs[0] / "report"
    check_output_dir(out, "--out")
    # refuse a folder without episodes, or a group of unlike episodes, before writing anything
    rows, _ = read_folders(args.dirs)
    check_baseline(rows, args.baseline)
    print(grouping_text(group_key(row) for row in rows))
    for path in write_report(args.dirs, out, baseline=args.baseline):
        print(f"wrote {path}")
    return 0
