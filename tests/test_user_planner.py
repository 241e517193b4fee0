"""A decision manager written outside the package: `--planner module:Class` in `sortsim run`
and in a sweep (two worker processes), its name in episodes.csv; refusals in one line."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from planner.decision.registry import make_planner
from planner.errors import PlannerInputError
from sim import config as episode_config
from sim.episode.runner import run_episode
from sim.results import outputs

USER_MODULE = '''
"""A user's decision manager: the most valuable reachable item, whatever its urgency."""

from planner.decision.candidates import candidates, choice_of


class MostValuable:
    name = "most-valuable"

    def reset(self):
        self.calls = 0

    def choose(self, items, robot, context):
        self.calls += 1
        cands = candidates(items, robot, context)
        if not cands:
            return None
        best = max(cands, key=lambda c: (c.expected_value, -c.exit_time))
        return choice_of(best, "most valuable")


class NoChoose:
    def reset(self):
        pass
'''
SHORT = ["--perception", "truth", "--items", "6", "--duration", "8", "--seed", "1", "--quiet"]


def _sortsim(*args, cwd):
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    return subprocess.run(
        [sys.executable, "-m", "sim.cli", *map(str, args)],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )


@pytest.fixture(scope="module")
def user_dir(tmp_path_factory):
    root = tmp_path_factory.mktemp("user")
    (root / "myplanners.py").write_text(USER_MODULE)
    return root


def test_a_user_planner_runs_in_sortsim_run_and_is_named_in_the_csv(user_dir):
    proc = _sortsim(
        "run", "--planner", "myplanners:MostValuable", *SHORT, "--out", "out", cwd=user_dir
    )
    assert proc.returncode == 0, proc.stderr
    [row] = outputs.read_rows(user_dir / "out" / "episodes.csv")
    assert row["planner"] == "myplanners:MostValuable"
    assert int(row["picked"]) >= 5  # 6 items, light belt: the user's planner really picks


def test_a_user_planner_by_file_path(user_dir, tmp_path):
    spec = f"{user_dir / 'myplanners.py'}:MostValuable"
    proc = _sortsim("run", "--planner", spec, *SHORT, "--out", tmp_path / "out", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    [row] = outputs.read_rows(tmp_path / "out" / "episodes.csv")
    assert row["planner"] == spec


def test_a_user_planner_object_in_run_episode(user_dir, cell, monkeypatch):
    monkeypatch.syspath_prepend(str(user_dir))
    planner = make_planner("myplanners:MostValuable")
    config = episode_config.load(None, perception="truth", items=6, duration_s=8.0, seed=1)
    result = run_episode(config, cell=cell, planner=planner)
    assert result.episode_row["planner"] == "most-valuable"
    assert planner.calls > 0 and result.episode_row["picked"] >= 5


def test_a_user_planner_in_a_two_worker_sweep(user_dir):
    (user_dir / "sweep.toml").write_text(
        """
[sweep]
name = "user"
speed_factors = [1.0]
items = [4]
planners = ["fifo", "myplanners:MostValuable"]
seeds = 1

[base]
perception = "truth"
duration_s = 3.0
"""
    )
    proc = _sortsim(
        "sweep", "--config", "sweep.toml", "--out", "swept", "--workers", "2", cwd=user_dir
    )
    assert proc.returncode == 0, proc.stderr
    rows = outputs.read_rows(user_dir / "swept" / "episodes.csv")
    assert [r["planner"] for r in rows] == ["fifo", "myplanners:MostValuable"]


@pytest.mark.parametrize(
    "spec, says",
    [
        ("nosuchmodule:X", "ModuleNotFoundError"),
        ("myplanners:Missing", "has no class Missing"),
        ("myplanners:NoChoose", "lacks choose() or reset()"),
        ("dice", "module:Class (a class with choose() and reset())"),
    ],
)
def test_a_bad_planner_spec_is_refused_in_one_line(user_dir, spec, says):
    proc = _sortsim("run", "--planner", spec, *SHORT, "--out", "never", cwd=user_dir)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and says in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (user_dir / "never").exists()


def test_make_planner_refuses_options_a_user_class_does_not_take(user_dir, monkeypatch):
    monkeypatch.syspath_prepend(str(user_dir))
    with pytest.raises(PlannerInputError, match="no options"):
        make_planner("myplanners:MostValuable", gamma=0.5)


def test_a_refusal_in_a_worker_stops_a_two_worker_sweep_within_seconds(user_dir):
    # The planner refuses when an episode starts, inside a worker process: the refusal must
    # cross back to the parent (it pickles) and stop the sweep with its one line.
    (user_dir / "refusing.py").write_text(
        """
from planner.errors import PlannerInputError


class Refusing:
    def reset(self):
        raise PlannerInputError("refusing option", "nothing, on purpose", 1)

    def choose(self, items, robot, context):
        return None
"""
    )
    (user_dir / "refused.toml").write_text(
        """
[sweep]
name = "refused"
speed_factors = [1.0]
items = [4]
planners = ["refusing:Refusing"]
seeds = 3

[base]
perception = "truth"
duration_s = 3.0
"""
    )
    t0 = time.monotonic()
    proc = _sortsim(
        "sweep", "--config", "refused.toml", "--out", "refused", "--workers", "2", cwd=user_dir
    )
    elapsed = time.monotonic() - t0
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith("sortsim sweep: refusing option")
    assert elapsed < 60.0  # it used to hang forever: the refusal did not unpickle
