"""A camera outage on a two-robot line: one camera against a camera per robot.

The same flow (camera perception, a coordinated line of two robots) with the first camera out
over [--from, --to) s, once with the scene's one camera and once with a camera per robot
(`[camera] per_robot`): prints the items never detected and the items binned of each
(docs/scenarios.md).

    python benchmarks/camera_outage_line.py [--items 24] [--duration 14] [--from 8] [--to 18]
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
from sim.episode.runner import config_cell  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Run the line with one camera and with a camera per robot, the first camera out."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--items", type=int, default=24)
    parser.add_argument("--duration", type=float, default=14.0, help="feed time [s]")
    parser.add_argument("--from", dest="start", type=float, default=8.0, help="outage [s]")
    parser.add_argument("--to", dest="end", type=float, default=18.0, help="camera back [s]")
    parser.add_argument("--seed", type=int, default=5)
    args = parser.parse_args(argv)
    outage = Fault("camera_outage", args.start, args.end - args.start, camera=0)
    for per_robot in (False, True):
        config = episode_config.from_dict(
            {
                "perception": "camera",
                "robots": 2,
                "coordination": "coordinated",
                "items": args.items,
                "duration_s": args.duration,
                "seed": args.seed,
                "camera": {"per_robot": per_robot},
            }
        )
        with Episode(config, config_cell(config), faults=FaultSchedule((outage,))) as episode:
            episode.reset()
            episode.run()
            m = episode.metrics
        cameras = "a camera per robot" if per_robot else "one camera"
        print(
            f"{cameras:18s} camera 0 out {args.start:g}-{args.end:g} s: never detected "
            f"{m.n_never_detected} of {m.n_entered}, binned {len(m.binned)}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
