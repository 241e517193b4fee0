"""`sortsim sweep`: the experiment grids of the thesis's tables (experiments/*.toml).

The whole config is validated before the first episode (a bad key or value stops it with one
line naming the key and the file, exit 2). Finished episodes are appended to
`<out>/episodes.csv` one row at a time; running the same sweep again skips them. At the end
the thesis's table is printed with our means beside its numbers and the matching figures are
saved as PNG files in `<out>`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim sweep`."""
    parser.add_argument("--config", type=Path, required=True, help="experiment TOML")
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    parser.add_argument(
        "--workers", type=int, default=None, help="local worker processes (default: CPU count)"
    )
    parser.add_argument(
        "--seeds",
        type=int,
        default=None,
        help="run only the first N seeds of each grid point (a reduced sweep; resumable)",
    )
    parser.add_argument(
        "--ray",
        default=None,
        metavar="ADDRESS",
        help="run on a Ray cluster ('local' starts one here; needs sortsim[cluster])",
    )


def main(args: argparse.Namespace) -> int:
    """Run the sweep's pending episodes, then print and plot the table."""
    from sim.errors import InvalidInput
    from sim.experiments import sweep_config, thesis_report
    from sim.experiments import sweep_runner as sweep

    config = sweep_config.load(args.config)
    if args.seeds is not None:
        if args.seeds < 1:
            raise InvalidInput("--seeds", "an integer >= 1", args.seeds)
        config = sweep_config.first_seeds(config, args.seeds)
    if args.workers is not None and args.workers < 1:
        raise InvalidInput("--workers", "an integer >= 1", args.workers)
    if args.ray is not None:
        sweep.require_ray(args.ray)

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    rows = sweep.run_sweep(config, args.out, args.workers, args.ray, progress=say)
    print(f"{config.name}: {len(rows)} episodes in {args.out / 'episodes.csv'}")
    table = thesis_report.format_table(config.table, rows)
    if table:
        print(table)
    for path in thesis_report.save_figures(config.table, rows, args.out):
        print(f"figure: {path}")
    return 0
