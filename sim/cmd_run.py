"""`sortsim run`: the closed-loop episode runner."""

from __future__ import annotations

import argparse
from pathlib import Path

from sim.errors import NotAvailable


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
        choices=["qlearning", "proximity", "fifo", "greedy", "oracle"],
        help="decision manager (default qlearning)",
    )
    parser.add_argument(
        "--perception",
        default=None,
        choices=["camera", "truth"],
        help="camera: rendered frames through the HMMs; truth: true codes",
    )
    parser.add_argument("--video", type=Path, default=None, help="write an MP4 of the episode")
    parser.add_argument("--out", type=Path, default=Path("runs/latest"), help="output folder")


def main(args: argparse.Namespace) -> int:
    """Not landed yet: refused with exit code 2."""
    raise NotAvailable("run: not yet available")
