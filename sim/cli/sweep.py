"""`sortsim sweep`: the experiment grids of the thesis's tables (experiments/*.toml).

The whole config is validated before the first episode (a bad key or value stops it with one
line naming the key, the file and the grid point, exit 2), and so are the output folder (an
`episodes.csv` of another sweep there is refused, not merged) and, for camera perception, the
rendering back-end. Finished episodes are appended to `<out>/episodes.csv` one row at a time,
each with the digest of the code it ran on (`code_digest`), their picks and timelines to
`picks.csv` and `timeline.csv` beside it; running the same sweep again skips them. A folder
whose episodes ran on other code (another digest) is refused in one line (exit 2, the folder
untouched) unless `--mix-code` says to add to it knowingly. A refusal raised
while an episode runs, in whichever worker process, stops the sweep with its one line. At the
end the thesis's table is printed with our means beside its numbers and the matching figures are
saved as PNG files in `<out>`.

The folder is locked from its checks to the figures (`sim.results.locks.FolderLock`): a second
sweep or run into it is refused in one line (exit 2) before any work. A folder whose disk fills
stops the sweep in one line (exit 1) with every row written before intact; the same command
resumes it.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

MAX_WORKERS = 256
"""Most local worker processes a sweep may start."""


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
    parser.add_argument(
        "--mix-code",
        action="store_true",
        help="add to a folder whose episodes ran on other code (another code digest); "
        "refused without it",
    )


def main(args: argparse.Namespace) -> int:
    """Run the sweep's pending episodes, then print and plot the table."""
    from sim.errors import InvalidInput
    from sim.experiments import sweep_config
    from sim.experiments import sweep_runner as sweep

    if args.seeds is not None and args.seeds < 1:
        raise InvalidInput("--seeds", "an integer >= 1", args.seeds)
    if args.workers is not None and not 1 <= args.workers <= MAX_WORKERS:
        raise InvalidInput("--workers", f"an integer 1..{MAX_WORKERS}", args.workers)
    config = sweep_config.load(args.config)
    if args.seeds is not None:
        config = sweep_config.first_seeds(config, args.seeds)
    if args.ray is not None:
        sweep.require_ray(args.ray)
    check_rendering(config)
    return run_locked(args, config)


def run_locked(args: argparse.Namespace, config) -> int:
    """The sweep run in its folder (`args.out`, `.workers`, `.ray`, `.mix_code`): the folder
    checked, locked, checked again, then the episodes pending."""
    from sim.experiments import sweep_runner as sweep
    from sim.results.locks import FolderLock

    sweep.check_out_dir(config, args.out, args.mix_code)
    with FolderLock(args.out, "--out"):
        sweep.check_out_dir(config, args.out, args.mix_code)  # again, now no other can write
        return _run(args, config)


def check_rendering(config) -> None:
    """Refuse, before any episode, what the sweep's camera episodes could not run without: the
    rendering back-end, the camera's calibration, the cache folder, the item classifier's
    training table."""
    if any(spec.config.perception == "camera" for spec in config.episodes):
        from perception.camera.calibration import CameraCalibration
        from sim.cell.camera import DEFAULT_CALIBRATION
        from sim.cell.rendering import check_backend
        from sim.user_cache import cache_dir

        CameraCalibration.load(DEFAULT_CALIBRATION)
        check_backend()
        cache_dir()  # SORTSIM_CACHE_DIR (or the platform's folder) created and tried
    if any(
        spec.config.perception == "camera" and spec.config.classifier != "hmm"
        for spec in config.episodes
    ):
        from sim.sensing.item_classifier import trained_item_classifier

        trained_item_classifier()  # a missing training table refused before any episode


def _run(args: argparse.Namespace, config) -> int:
    """The sweep's work once its folder is locked: manifest, episodes, table and figures."""
    from sim.cli.run import Progress
    from sim.experiments import sweep_runner as sweep

    sweep.write_manifest(config, args.out)

    log = logging.getLogger("sim.experiments.sweep")
    # On a terminal a bar with the ETA is redrawn in place (the per-episode lines go to
    # --verbose); elsewhere (logs, CI) each episode's line is printed.
    bar = Progress() if sys.stderr.isatty() and log.isEnabledFor(logging.INFO) else None
    line = log.debug if bar else log.info
    rows = sweep.run_sweep(
        config, args.out, args.workers, args.ray, progress=line, bar=bar, mix_code=args.mix_code
    )
    if bar:
        bar.done()
    print(f"{config.name}: {len(rows)} episodes in {args.out / 'episodes.csv'}")
    from sim.experiments.thesis import thesis_report

    table = thesis_report.format_table(config.table, rows)
    if table:
        print(table)
    for path in thesis_report.save_figures(config.table, rows, args.out):
        print(f"figure: {path}")
    return 0
