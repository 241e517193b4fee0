"""A robot stopped on a two-robot line split by material: what the robot still running picks.

Robot 0 sorts paper and plastic, robot 1 aluminium (coordinated, truth, 50 mm cups); the same
flow with and without a protective stop of robot 1 over [--from, --to) s. Prints each robot's
successful picks started in that window and the line's totals (docs/scenarios.md).

    python benchmarks/robot_stop_line.py [--items 100] [--duration 60] [--from 20] [--to 50]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim import config as episode_config  # noqa: E402
from sim.config.faults import Fault, FaultSchedule  # noqa: E402
from sim.episode.loop import Episode  # noqa: E402
from sim.episode.runner import shared_cell  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Run the line with and without the stop; print the picks in the stop's window."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--items", type=int, default=100)
    parser.add_argument("--duration", type=float, default=60.0, help="feed time [s]")
    parser.add_argument("--from", dest="start", type=float, default=20.0, help="stop [s]")
    parser.add_argument("--to", dest="end", type=float, default=50.0, help="restart [s]")
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args(argv)
    config = episode_config.from_dict(
        {
            "perception": "truth",
            "items": args.items,
            "duration_s": args.duration,
            "seed": args.seed,
            "coordination": "coordinated",
            "cup": {"diameter_m": 0.05},
            "robots": [{"materials": ["paper", "plastic"]}, {"materials": ["aluminium"]}],
        }
    )
    cell = shared_cell(config.cell_settings, config.item_catalogue, 2, config.line_cell)
    stop = Fault("robot_stop", args.start, args.end - args.start, robot=1)
    for name, faults in (("no stop", ()), ("robot 1 stopped", (stop,))):
        with Episode(config, cell, faults=FaultSchedule(faults)) as episode:
            episode.reset()
            episode.run()
            picks, row = episode.metrics.pick_rows(), episode.metrics.row()
        during = [p["robot"] for p in picks if p["success"] and stop.active(p["t_start_s"])]
        print(
            f"{name:16s} picks started in {args.start:g}-{args.end:g} s: robot 0 "
            f"{during.count(0)}, robot 1 {during.count(1)}; the line: picked {row['picked']} "
            f"of {row['entered']}, missed {row['missed']}, dropped {row['dropped']}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
