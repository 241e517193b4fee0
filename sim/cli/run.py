"""`sortsim run`: one closed-loop episode of the sorting cell.

Writes `<out>/episodes.csv`, `<out>/picks.csv` and, with `--video`, the MP4; prints a progress
line on stderr while it runs and a one-screen summary at the end. The config (TOML and
options) is validated before anything is simulated: a refused value exits with code 2 and one
line naming it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from planner.decision.registry import PLANNERS


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim run`."""
    parser.add_argument("--config", type=Path, help="TOML file; command-line options override it")
    parser.add_argument("--seed", type=int, default=None, help="random seed (default 0)")
    parser.add_argument(
        "--items", type=int, default=None, help="items in the episode (default 100)"
    )
    parser.add_argument(
        "--speed-factor",
        type=float,
        default=None,
        help="belt speed factor: 1, 1.2 or 1.5 of 0.185 m/s (default 1)",
    )
    parser.add_argument(
        "--planner",
        default=None,
        metavar="NAME|module:Class",
        help=f"decision manager: {' | '.join(PLANNERS)}, or module:Class of your own "
        "(default qlearning)",
    )
    parser.add_argument(
        "--perception",
        default=None,
        choices=["camera", "truth"],
        help="camera: rendered frames through the HMMs; truth: true codes",
    )
    parser.add_argument("--video", type=Path, default=None, help="write an MP4 of the episode")
    parser.add_argument("--out", type=Path, default=Path("runs/latest"), help="output folder")
    parser.add_argument(
        "--duration", type=float, default=None, help="seconds over which the items arrive (90)"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress line")


class Progress:
    """A one-line progress bar on stderr (redrawn in place on a terminal, else every 10 %)."""

    def __init__(self, stream=sys.stderr, width: int = 30):
        self.stream = stream
        self.width = width
        self.tty = stream.isatty()
        self._last_decile = -1

    def __call__(self, fraction: float, text: str) -> None:
        fraction = min(max(fraction, 0.0), 1.0)
        if self.tty:
            filled = int(round(fraction * self.width))
            bar = "#" * filled + "." * (self.width - filled)
            self.stream.write(f"\r[{bar}] {fraction:4.0%} {text}\x1b[K")
            self.stream.flush()
        elif int(fraction * 10) > self._last_decile:
            self._last_decile = int(fraction * 10)
            self.stream.write(f"{fraction:4.0%} {text}\n")
            self.stream.flush()

    def done(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


def summary(result) -> str:
    """The one-screen summary of an episode."""
    r, c = result.episode_row, result.config
    lines = [
        f"episode: seed {c.seed}, {c.items} items over {c.duration_s:g} s, "
        f"belt x{c.speed_factor:g} ({c.belt_speed_mps:.3f} m/s), planner {c.planner}, "
        f"perception {c.perception}",
        f"entered the belt (SI)  {r['entered']:>6}   "
        f"(paper {r['entered_paper']}, plastic {r['entered_plastic']}, "
        f"aluminium {r['entered_aluminium']})",
        f"picked into bins (SP)  {r['picked']:>6}   "
        f"(paper {r['picked_paper']}, plastic {r['picked_plastic']}, "
        f"aluminium {r['picked_aluminium']})",
        f"wrong bin              {r['wrong_bin']:>6}",
        f"missed (left the belt) {r['missed']:>6}",
        f"dropped                {r['dropped']:>6}",
        f"pick attempts          {r['attempts']:>6}   (failed {r['failed_picks']})",
        f"accuracy SP/SI         {r['accuracy']:>9.4f}",
        f"profit                 {r['profit_eur']:>9.2f} EUR",
        f"mean cycle             {r['mean_cycle_s']:>9.3f} s",
        f"simulated              {r['sim_s']:>9.1f} s in {r['wall_s']:.1f} s wall "
        f"({r['real_time_factor']:.1f}x real time)",
    ]
    timing = getattr(result, "timings", None)
    if timing:
        keys = ("physics", "perception", "decision", "planning", "video")
        parts = ", ".join(f"{k} {timing[k]:.1f} s" for k in keys if k in timing)
        lines.append(f"wall time by stage     {parts}")
    return "\n".join(lines)


def main(args: argparse.Namespace) -> int:
    """Run one episode and write its files."""
    from sim.episode import config as episode_config
    from sim.episode import outputs

    config = episode_config.load(
        args.config,
        seed=args.seed,
        items=args.items,
        speed_factor=args.speed_factor,
        planner=args.planner,
        perception=args.perception,
        duration_s=args.duration,
    )
    from sim.episode.runner import run_episode

    progress = None if args.quiet else Progress()
    result = run_episode(config, video_path=args.video, progress=progress)
    if progress is not None:
        progress.done()
    out = Path(args.out)
    outputs.write_episodes(out / "episodes.csv", [result.episode_row])
    outputs.write_picks(out / "picks.csv", result.pick_rows)
    print(summary(result))
    written = [out / "episodes.csv", out / "picks.csv"] + ([args.video] if args.video else [])
    print("wrote " + ", ".join(str(p) for p in written))
    return 0
