"""`sortsim cycle`: the Cycle 1 runner."""

from __future__ import annotations

import argparse

from sim.errors import NotAvailable


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim cycle`."""
    parser.add_argument("--payload", type=float, default=1.0, help="payload mass [kg] (0 to 3)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def main(args: argparse.Namespace) -> int:
    """Not landed yet: refused with exit code 2."""
    raise NotAvailable("cycle: not yet available")
