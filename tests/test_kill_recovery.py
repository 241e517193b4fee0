"""kill -9 of a run and of a sweep: nothing finished is lost, nothing is left behind after the
next start.

Each test starts the real command line in a subprocess, waits until the work is under way,
kills it with SIGKILL (no Python cleanup can run), checks that the results already there are
intact, then starts the command again and checks that the hidden temporary files of the killed
process are gone and the results are complete.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sim.paths import REPO_ROOT
from sim.results import outputs
from sim.results.locks import LOCK_FILE

ENV = {**os.environ, "MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl"}


def _start(*args) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "sim.cli.main", *map(str, args)],
        cwd=REPO_ROOT,
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def _run(*args, timeout: float = 240) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "sim.cli.main", *map(str, args)],
        cwd=REPO_ROOT,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def _wait_for(condition, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    """Poll `condition()` until it holds; fail if the process ended or time ran out."""
    end = time.monotonic() + timeout
    while not condition():
        assert proc.poll() is None, f"ended before it was killed: {proc.stderr.read()}"
        assert time.monotonic() < end, "the work never got under way"
        time.sleep(0.05)


def _kill(proc: subprocess.Popen) -> None:
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL


def _hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.mark.slow
def test_killed_run_with_video_keeps_the_earlier_results_and_its_temporary_goes(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    earlier = {
        "episodes.csv": "seed,profit_eur\n0,12.5\n",
        "picks.csv": "t_start_s,success\n1.0,1\n",
        "video.mp4": "an earlier run's video",
    }
    for name, text in earlier.items():
        (out / name).write_text(text, encoding="utf-8")
    proc = _start(
        "run", "--perception", "truth", "--items", "30", "--duration", "30",
        "--out", out, "--video", out / "video.mp4", "--quiet",
    )  # fmt: skip
    _wait_for(lambda: any(n.endswith(".mp4") for n in _hidden(out)), proc)
    time.sleep(1.0)  # frames are being encoded: well into the episode
    _kill(proc)

    for name, text in earlier.items():  # the killed run replaced nothing
        assert (out / name).read_text(encoding="utf-8") == text
    # Its temporary MP4, if its video process has not dropped it yet (it does once it sees the
    # run's process gone: tests/test_video_process.py).
    # Its lock file stays too (the kernel let the lock go; the next run takes it and removes it).
    left = [name for name in _hidden(out) if name != LOCK_FILE]
    assert all(str(proc.pid) in name for name in left), left

    again = _run(
        "run", "--perception", "truth", "--items", "1", "--duration", "1",
        "--out", out, "--video", out / "video.mp4", "--quiet",
    )  # fmt: skip
    assert again.returncode == 0, again.stderr
    assert _hidden(out) == []
    assert len(outputs.read_rows(out / "episodes.csv")) == 1
    assert (out / "video.mp4").stat().st_size > 1000


GRID = """[sweep]
name = "killed"
items = [2]
planners = ["proximity", "greedy", "fifo"]
seeds = 1

[base]
perception = "truth"
duration_s = 2.0
"""


def test_killed_sweep_resumes_with_every_finished_row_and_no_leftovers(tmp_path):
    config = tmp_path / "grid.toml"
    config.write_text(GRID, encoding="utf-8")
    out = tmp_path / "out"
    proc = _start("sweep", "--config", config, "--out", out, "--workers", "1")
    csv_path = out / "episodes.csv"
    _wait_for(lambda: csv_path.exists() and len(outputs.read_rows(csv_path)) >= 1, proc)
    _kill(proc)

    finished = csv_path.read_text(encoding="utf-8").splitlines()
    done = len(finished) - 1
    assert 1 <= done < 3
    # A kill can land while a row is being written: its temporary is then left beside the file.
    (out / f".episodes.csv.{proc.pid}.0badc0de.tmp").write_text(finished[0] + "\nhalf a ro")

    again = _run("sweep", "--config", config, "--out", out, "--workers", "1")
    assert again.returncode == 0, again.stderr
    assert f"{3 - done} of 3 episodes to run ({done} done)" in again.stderr
    final = csv_path.read_text(encoding="utf-8").splitlines()
    assert len(final) == 4
    assert all(line in final for line in finished)  # finished rows kept, byte for byte
    assert [r["planner"] for r in outputs.read_rows(csv_path)] == ["proximity", "greedy", "fifo"]
    assert _hidden(out) == []
