"""The `sortsim` command line: one subcommand per module `sim.cli.<name>`.

Each command module defines `add_arguments(parser)` and `main(args) -> int` and keeps its heavy
imports inside `main`, so `sortsim --help` stays fast. Exit codes (docs/architecture.md): 0 done,
2 refused input (one line on stderr naming the field and what is allowed), 1 anything else (a
deliberate error in one line too, and so is a failure of the machine's storage, `STORAGE_ERRORS`:
a full disk, a read-only file system; a bug with its traceback), 128 + N when stopped by signal
N.

Before a command runs, MuJoCo's rendering back-end is made safe to import
(`sim.cell.rendering.prepare_environment`), and SIGTERM and SIGHUP are turned into an orderly
stop, so the command's temporary files are removed as after Ctrl-C (a SIGKILLed run's are
removed by the next run).
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import logging
import os
import signal
import sys
from collections.abc import Iterator

from sim.errors import RefusedInput, SortsimError

COMMANDS = {
    "run": "Run one episode of the sorting cell and write episodes.csv, picks.csv, video.",
    "sweep": "Run a grid of episodes from a TOML config (the thesis's tables).",
    "cycle": "Run ABB's Cycle 1 (25-305-25 mm) in physics and report the cycle time.",
    "calibrate": "Calibrate the cell camera from rendered checkerboard views.",
    "hmm-eval": "Train the per-stripe HMMs and print the thesis's table 4.1.",
    "bench": "Print the performance figures (real-time factors, latencies, cycle time).",
    "train": "Train the learned pick-order policy on sortsim/PickOrder-v0 (seeded).",
    "report": "Means with 95-percent intervals, figures and an HTML page of run or sweep folders.",
    "view": "Show one episode live in MuJoCo's interactive viewer (needs a display).",
    "reproduce": "The thesis's chapter 4, every table and figure, from sweeps of the current code.",
    "frames": "Write the belt camera's frames of one episode as a labelled COCO data set.",
    "advise": "Which line to buy: robots x belt speeds swept until a plant's targets decide.",
}

STORAGE_ERRORS = frozenset(
    {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EIO, errno.EFBIG, errno.ENOMEM}
)
"""OS errors of the storage (not of the code): said in one line, exit code 1."""


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
    from sim import __version__

    parser.add_argument("--version", action="version", version=f"sortsim {__version__}")
    sub = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=_OneLineParser
    )
    common = _common_options()
    for name, summary in COMMANDS.items():
        p = sub.add_parser(name, help=summary, description=summary, parents=[common])
        _module(name).add_arguments(p)
    return parser


def _common_options() -> _OneLineParser:
    """--verbose / --quiet, taken by every subcommand (the standard `logging` levels)."""
    common = _OneLineParser(add_help=False)
    loudness = common.add_mutually_exclusive_group()
    loudness.add_argument("-v", "--verbose", action="store_true", help="debug messages too")
    loudness.add_argument(
        "-q", "--quiet", action="store_true", help="warnings and errors only (no progress)"
    )
    return common


def configure_logging(verbose: bool, quiet: bool) -> None:
    """Messages of the `sim`, `planner` and `perception` loggers on stderr: DEBUG with
    --verbose, WARNING and above with --quiet, else INFO (progress included)."""
    level = logging.DEBUG if verbose else logging.WARNING if quiet else logging.INFO
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    for name in ("sim", "planner", "perception"):
        logger = logging.getLogger(name)
        logger.handlers[:] = [handler]
        logger.setLevel(level)
        logger.propagate = False


class Stopped(BaseException):
    """A stop asked by a signal (SIGTERM, SIGHUP): unwinds like Ctrl-C, cleaning up."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _stop(signum: int, frame) -> None:
    raise Stopped(signum)


@contextlib.contextmanager
def _orderly_stops() -> Iterator[None]:
    """SIGTERM and SIGHUP raise `Stopped` while a command runs (main thread only)."""
    saved = {}
    try:
        for sig in (signal.SIGTERM, signal.SIGHUP):
            saved[sig] = signal.signal(sig, _stop)
    except ValueError:  # not the main thread: leave the signals alone
        pass
    try:
        yield
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)


def _say(command: str, text: object) -> None:
    """The command's one line on stderr."""
    print(f"sortsim {command}: {' '.join(str(text).split())}", file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the process exit code."""
    try:
        args = build_parser().parse_args(argv)
    except KeyboardInterrupt:  # Ctrl-C while the commands are imported
        print("sortsim: interrupted", file=sys.stderr, flush=True)
        return 130
    configure_logging(args.verbose, args.quiet)
    from sim.cell.rendering import prepare_environment

    prepare_environment()
    try:
        with _orderly_stops():
            return int(_module(args.command).main(args) or 0)
    except RefusedInput as exc:
        _say(args.command, exc)
        return 2
    except SortsimError as exc:
        _say(args.command, f"error: {exc}")
        return 1
    except BrokenPipeError:  # the reader of stdout went away (e.g. `| head`)
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as exc:
        if exc.errno not in STORAGE_ERRORS:
            raise
        where = f": {exc.filename}" if exc.filename else ""
        _say(args.command, f"error: {exc.strerror or type(exc).__name__}{where}")
        return 1
    except ImportError as exc:  # a module's import cut short by Ctrl-C
        if not _interrupted(exc):
            raise
        _say(args.command, "interrupted")
        return 130
    except KeyboardInterrupt:
        _say(args.command, "interrupted")
        return 130
    except Stopped as exc:
        _say(args.command, f"stopped by {signal.Signals(exc.signum).name}")
        return 128 + exc.signum


def _interrupted(exc: BaseException | None) -> bool:
    """Whether `exc` was caused by a Ctrl-C (a KeyboardInterrupt in its chain of causes)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


if __name__ == "__main__":
    sys.exit(main())
