"""`sortsim sweep`: the experiment sweeps."""

from __future__ import annotations

import argparse
from pathlib import Path

from sim.errors import NotAvailable


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim sweep`."""
    parser.add_argument("--config", type=Path, required=True, help="experiment TOML")
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    parser.add_argument("--workers", type=int, default=None, help="local worker processes")
    parser.add_argument("--ray", default=None, metavar="ADDRESS", help="run on a Ray cluster")


def main(args: argparse.Namespace) -> int:
    """Not landed yet: refused with exit code 2."""
    raise NotAvailable("sweep: not yet available")
