"""The `sortsim` command line: one subcommand per module `sim.cli.<name>`.

Each command module defines `add_arguments(parser)` and `main(args) -> int` and keeps its heavy
imports inside `main`, so `sortsim --help` stays fast. Exit codes (docs/architecture.md): 0 done,
2 refused input (one line on stderr naming the field and what is allowed), 1 anything else.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from sim.errors import NotAvailable, RefusedInput

COMMANDS = {
    "run": "Run one episode of the sorting cell and write episodes.csv, picks.csv, video.",
    "sweep": "Run a grid of episodes from a TOML config (the thesis's tables).",
    "cycle": "Run ABB's Cycle 1 (25-305-25 mm) in physics and report the cycle time.",
    "calibrate": "Calibrate the cell camera from rendered checkerboard views.",
    "hmm-eval": "Train the per-stripe HMMs and print the thesis's table 4.1.",
    "bench": "Print the performance figures (real-time factors, latencies, cycle time).",
}

REFUSED = (RefusedInput, NotAvailable)


class _OneLineParser(argparse.ArgumentParser):
    """Refuses bad options in one line (no usage dump), exit code 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: {message}\n")


def _module(name: str):
    return importlib.import_module("sim.cli." + name.replace("-", "_"))


def build_parser() -> argparse.ArgumentParser:
    """The full parser, every subcommand with its own `--help`."""
    parser = _OneLineParser(
        prog="sortsim", description="Physics digital twin of a robotic recycling sorting cell."
    )
    sub = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=_OneLineParser
    )
    for name, summary in COMMANDS.items():
        p = sub.add_parser(name, help=summary, description=summary)
        _module(name).add_arguments(p)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the process exit code."""
    args = build_parser().parse_args(argv)
    try:
        return int(_module(args.command).main(args) or 0)
    except REFUSED as exc:
        print(f"sortsim {args.command}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"sortsim {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
