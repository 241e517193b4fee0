"""The console script: every subcommand answers --help, and refusals exit 2 in one line."""

from __future__ import annotations

import subprocess
import sys

import pytest

from sim.cli.main import COMMANDS, build_parser, main


def test_top_level_help_lists_every_command(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert name in out


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_each_subcommand_has_help(name, capsys):
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0
    assert "usage: sortsim " + name in capsys.readouterr().out


def test_unknown_planner_is_refused_with_exit_2():
    proc = subprocess.run(
        [sys.executable, "-m", "sim.cli.main", "run", "--planner", "dice"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    assert "planner" in proc.stderr
    assert "qlearning" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_parser_builds_without_heavy_imports():
    before = set(sys.modules)
    build_parser()
    assert "mujoco" not in set(sys.modules) - before or "mujoco" in before
