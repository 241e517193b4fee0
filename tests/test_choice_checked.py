"""A user's decision manager whose `choose()` returns something else than a `Choice` or None
ends the episode in one line naming its class, `choose()` and the type expected (exit code 1),
from `sortsim run` and from a sweep's worker process alike."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys

import pytest

from planner.decision.interface import Choice
from planner.decision.registry import ChoiceTypeError, ask_manager

USER_MODULE = '''
"""Decision managers that return the wrong thing."""


class ReturnsTheItem:
    def reset(self):
        pass

    def choose(self, items, robot, context):
        return items[0] if items else None


class ReturnsAnId:
    def reset(self):
        pass

    def choose(self, items, robot, context):
        return items[0].item_id if items else None
'''
SHORT = ["--perception", "truth", "--items", "5", "--duration", "3", "--quiet"]
EXPECTED = "it must return a planner.decision.interface.Choice or None"


def _sortsim(*args, cwd):
    env = dict(os.environ, MUJOCO_GL="egl", PYOPENGL_PLATFORM="egl")
    return subprocess.run(
        [sys.executable, "-m", "sim.cli", *map(str, args)],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.fixture(scope="module")
def user_dir(tmp_path_factory):
    root = tmp_path_factory.mktemp("wrong")
    (root / "wrongplanners.py").write_text(USER_MODULE)
    return root


def test_run_says_in_one_line_what_choose_returned(user_dir):
    proc = _sortsim(
        "run", "--planner", "wrongplanners:ReturnsTheItem", *SHORT, "--out", "out", cwd=user_dir
    )
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert lines[0] == (
        "sortsim run: error: ReturnsTheItem.choose() returned a "
        f"planner.decision.interface.TrackedItem; {EXPECTED}"
    )
    assert not (user_dir / "out" / "episodes.csv").exists()


def test_a_sweeps_worker_stops_the_sweep_with_the_same_line(user_dir):
    (user_dir / "sweep.toml").write_text(
        """
[sweep]
name = "wrong"
speed_factors = [1.0]
items = [5]
planners = ["fifo", "wrongplanners:ReturnsAnId"]
seeds = 1

[base]
perception = "truth"
duration_s = 3.0
"""
    )
    proc = _sortsim(
        "sweep", "--config", "sweep.toml", "--out", "swept", "--workers", "2", cwd=user_dir
    )
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr and "SpawnPoolWorker" not in proc.stderr, proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == (
        f"sortsim sweep: error: ReturnsAnId.choose() returned a int; {EXPECTED}"
    )


def test_a_choice_or_none_passes_and_the_error_pickles():
    choice = Choice(item_id=1, expected_value=0.2, meet_time=1.0, bin_class=2, reason="x")

    class Gives:
        def __init__(self, value):
            self.value = value

        def choose(self, items, robot, context):
            return self.value

    assert ask_manager(Gives(choice), [], None, None) is choice
    assert ask_manager(Gives(None), [], None, None) is None
    with pytest.raises(ChoiceTypeError) as raised:
        ask_manager(Gives({"item_id": 1}), [], None, None)
    again = pickle.loads(pickle.dumps(raised.value))
    assert str(again) == str(raised.value) == f"Gives.choose() returned a dict; {EXPECTED}"


def test_the_expected_type_is_named_as_the_class_is():
    from planner.decision.interface import Choice
    from planner.decision.registry import CHOICE_TYPE

    assert CHOICE_TYPE == f"{Choice.__module__}.{Choice.__qualname__}"
