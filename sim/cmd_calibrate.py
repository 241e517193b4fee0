"""`sortsim calibrate`: the camera calibration."""

from __future__ import annotations

import argparse
from pathlib import Path

from sim.errors import NotAvailable


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim calibrate`."""
    parser.add_argument("--out", type=Path, default=None, help="where to write the calibration")


def main(args: argparse.Namespace) -> int:
    """Not landed yet: refused with exit code 2."""
    raise NotAvailable("calibrate: not yet available")
