"""`sortsim hmm-eval`: the HMM evaluation."""

from __future__ import annotations

import argparse

from sim.errors import NotAvailable


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim hmm-eval`."""
    parser.add_argument(
        "--perception",
        default="truth",
        choices=["truth", "camera"],
        help="score on true observation codes or on camera codes",
    )


def main(args: argparse.Namespace) -> int:
    """Not landed yet: refused with exit code 2."""
    raise NotAvailable("hmm-eval: not yet available")
