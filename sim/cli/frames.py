"""`sortsim frames`: the belt camera's frames of one episode as a labelled data set (COCO).

The episode is the one `sortsim run` would run with the same options (`--config`, `--seed`,
`--items`, `--duration`, `--speed-factor`, `--robots`, `--catalogue`, the world's numbers, ...;
`sim.cli.run.add_episode_arguments`): the robots pick as usual while the camera's frames are
kept at every observation (`--every N`: every N-th), with their depth maps and one mask per
item in view (`sim.evaluation.frames`, docs/perception.md). `--perception truth` runs the
episode faster (no perception to render) and keeps the same kind of frames; the robots then
pick what truth perception reports.

Refused in one line (exit code 2) before any work: everything `sortsim run` refuses of the
config, an `--out` that could not be written or that holds something else than an earlier data
set (an empty or new folder, or one holding a `sortsim frames` data set, which is replaced
whole), `--every` below 1, and a missing rendering back-end (`MUJOCO_GL=egl`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sim.cli.run import add_episode_arguments


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim frames`: the episode's (as `sortsim run`), the folder, the thinning."""
    add_episode_arguments(parser)
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("runs/frames"),
        help="the data set's folder: images/, depth/, annotations.json (an earlier data set "
        "there is replaced whole)",
    )
    parser.add_argument(
        "--every",
        type=int,
        default=1,
        metavar="N",
        help="keep the frame of every N-th camera observation (default 1: each, every 0.5 s)",
    )
    parser.add_argument(
        "--keep-empty", action="store_true", help="keep frames with no item in view too"
    )


def main(args: argparse.Namespace) -> int:
    """Run one episode and write its camera frames as a data set."""
    from sim.cli.run import Progress, check_perception, load_config
    from sim.evaluation import frames

    config = load_config(args)
    out = frames.check_out(Path(args.out))
    every = frames.check_every(args.every)
    check_perception(config)
    from sim.cell.rendering import check_backend

    check_backend()
    frames.remove_stale(out)
    progress = None if args.quiet else Progress()
    result = frames.record_frames(config, out, every, args.keep_empty, progress)
    if progress is not None:
        progress.done()
    row = result.episode_row
    print(
        f"episode: seed {config.seed}, {config.items} items over {config.duration_s:g} s, "
        f"perception {config.perception}: entered {row['entered']}, picked {row['picked']}, "
        f"never visible {'-' if row['never_visible'] is None else row['never_visible']}"
    )
    print(
        f"frames: {result.images} of {result.observations} observations, "
        f"{result.annotations} item masks"
    )
    print(f"wrote {result.out}/ (images/, depth/, {frames.ANNOTATIONS})")
    return 0
