"""Standard logging on the command line: --verbose / --quiet on every subcommand, a sweep's
progress lines with their ETA at INFO (gone with --quiet)."""

from __future__ import annotations

import logging
import subprocess
import sys

import pytest

from sim.cli.main import COMMANDS, build_parser, configure_logging
from sim.experiments.sweep_runner import eta_text

TINY = (
    '[sweep]\nname = "tiny"\nspeed_factors = [1.0]\nitems = [3]\nplanners = ["fifo"]\nseeds = 2\n'
    '[base]\nperception = "truth"\nduration_s = 3.0\n'
)


def test_eta_text():
    assert eta_text(100.0, 2, 3) == "ETA 2 min 30 s"
    assert eta_text(10.0, 5, 1) == "ETA 2 s"
    assert eta_text(3600.0, 1, 2) == "ETA 2 h 0 min"
    assert eta_text(5.0, 0, 4) == "ETA unknown"
    assert eta_text(5.0, 3, 0) == "done"


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_subcommand_takes_verbose_and_quiet(name):
    parser = build_parser()
    sweep_like = ["--config", "c.toml", "--out", "o"]
    required = {"report": ["DIR"], "sweep": sweep_like, "advise": sweep_like}
    positional = required.get(name, [])
    assert parser.parse_args([name, *positional, "--verbose"]).verbose
    assert parser.parse_args([name, *positional, "-q"]).quiet
    with pytest.raises(SystemExit) as exc:
        parser.parse_args([name, *positional, "--verbose", "--quiet"])
    assert exc.value.code == 2


def test_levels():
    for flags, level in (((True, False), logging.DEBUG), ((False, True), logging.WARNING)):
        configure_logging(*flags)
        assert logging.getLogger("sim").level == level
    configure_logging(False, False)
    assert logging.getLogger("planner").level == logging.INFO


def _sweep(tmp_path, *flags):
    tmp_path.mkdir()
    config = tmp_path / "tiny.toml"
    config.write_text(TINY)
    return subprocess.run(
        [sys.executable, "-m", "sim.cli.main", "sweep", "--config", str(config)]
        + ["--out", str(tmp_path / "out"), "--workers", "1", *flags],
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_sweep_progress_has_an_eta_and_quiet_hides_it(tmp_path):
    loud = _sweep(tmp_path / "a")
    assert loud.returncode == 0, loud.stderr
    progress = [line for line in loud.stderr.splitlines() if "[1/2]" in line]
    assert progress and "INFO sim.experiments.sweep:" in progress[0] and "ETA" in progress[0]
    quiet = _sweep(tmp_path / "b", "--quiet")
    assert quiet.returncode == 0, quiet.stderr
    assert quiet.stderr.strip() == ""
