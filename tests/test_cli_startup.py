"""The command line starts light: building its parser imports no physics or numerics library.

`sim.cli.main` imports every subcommand module to build the parser, and each keeps its heavy
imports inside its `main` (so `sortsim --help` answers at once). Inside a test session these
libraries are already imported by other tests, so the check runs in a fresh interpreter: it
imports `sim.cli.main`, builds the parser (and asks every subcommand for its --help) and
reports which of the heavy top-level packages ended up in `sys.modules`.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
HEAVY = (
    "mujoco",
    "numpy",
    "scipy",
    "cv2",
    "sklearn",
    "matplotlib",
    "ruckig",
    "imageio",
    "imageio_ffmpeg",
    "hmmlearn",
    "ray",
)

_CHILD = """
import contextlib, io, json, sys
heavy = {heavy!r}
report = {{"before": sorted(m for m in heavy if m in sys.modules)}}

def loaded():
    return sorted({{name.partition(".")[0] for name in sys.modules}} & set(heavy))

import sim.cli.main as cli
report["file"] = cli.__file__
report["import"] = loaded()
cli.build_parser()
report["parser"] = loaded()
report["commands"] = list(cli.COMMANDS)
for argv in [["--help"]] + [[name, "--help"] for name in cli.COMMANDS]:
    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
        cli.main(argv)
    report[" ".join(argv)] = loaded()
{extra}
print(json.dumps(report))
"""


def child(extra: str = "") -> dict:
    """Run the check in a fresh interpreter from the repository's root; its JSON report: the
    heavy packages loaded after the import, after building the parser and after each --help
    (cumulative)."""
    code = _CHILD.format(heavy=HEAVY, extra=extra)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONSTARTUP"}
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    assert report["before"] == [], report  # nothing heavy preloaded (sitecustomize, ...)
    assert Path(report["file"]).resolve().is_relative_to(REPO), report["file"]
    return report


@pytest.fixture(scope="module")
def report() -> dict:
    """The fresh interpreter's report."""
    return child()


def test_importing_the_command_line_imports_nothing_heavy(report):
    assert report["import"] == [], report


def test_building_the_parser_imports_nothing_heavy(report):
    assert report["parser"] == [], report


def test_every_help_imports_nothing_heavy(report):
    assert {"run", "sweep", "cycle", "calibrate", "hmm-eval", "bench"} <= set(report["commands"])
    assert report["--help"] == [], report
    for name in report["commands"]:
        assert report[f"{name} --help"] == [], (name, report)


def test_the_check_sees_a_heavy_import():
    # The probe itself works: importing the episode runner pulls in MuJoCo and numpy.
    late = child(extra='import sim.episode.runner\nreport["late"] = loaded()')
    assert {"mujoco", "numpy"} <= set(late["late"]), late
