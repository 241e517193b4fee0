"""Nothing lost: outputs that cannot be written, full disks, a failing video, folders in use.

Every test starts the real command line (tiny truth episodes) and checks the one line on stderr,
the exit code, that what was written is intact, and that no folder mixes two runs. The full
and read-only disks are small tmpfs mounts (root with mount permission; skipped otherwise).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sim.paths import REPO_ROOT
from sim.results import outputs
from sim.results.locks import LOCK_FILE, FolderLock

ENV = {**os.environ, "MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl"}
TINY = ["--items", "5", "--duration", "3", "--perception", "truth", "--quiet"]
LONGER = ["--items", "60", "--duration", "30", "--perception", "truth", "--quiet"]
"""A run that lasts seconds after it takes its folder's lock, longer than a second command's
start-up, however fast the machine."""
PAGE = 4096
SWEEP = """
[sweep]
name = "nothing-lost"
speed_factors = [1.0]
items = [{items}]
planners = ["proximity", "greedy"]
seeds = {seeds}

[base]
perception = "truth"
duration_s = {duration}
"""


def _command(*args) -> list[str]:
    return [sys.executable, "-m", "sim.cli.main", *map(str, args)]


def _run(*args, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        _command(*args), cwd=REPO_ROOT, env=ENV, capture_output=True, text=True, timeout=timeout
    )


def _start(*args, **kwargs) -> subprocess.Popen:
    return subprocess.Popen(
        _command(*args),
        cwd=REPO_ROOT,
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        **kwargs,
    )


def _one_line(stderr: str) -> str:
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr
    return lines[0]


def _wait_for(condition, proc: subprocess.Popen, timeout: float = 300.0) -> None:
    end = time.monotonic() + timeout
    while not condition():
        assert proc.poll() is None, f"ended early: {proc.stderr.read()}"
        assert time.monotonic() < end, "never got under way"
        time.sleep(0.02)


@contextlib.contextmanager
def _tmpfs(path: Path, size: str, read_only: bool = False):
    """A tmpfs of `size` mounted at `path` (skips the test when mounting is not permitted)."""
    if os.name != "posix" or os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("a tmpfs mount needs root and mount(8): the full-disk tests cannot run")
    path.mkdir(parents=True, exist_ok=True)
    options = f"size={size}" + (",ro" if read_only else "")
    proc = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
        capture_output=True,
        text=True,
    )
    if proc.returncode != 0:
        pytest.skip(f"mounting a tmpfs is not permitted here: {proc.stderr.strip()}")
    try:
        yield path
    finally:
        subprocess.run(["umount", "-l", str(path)], capture_output=True)


def _fill(folder: Path, free_pages: int) -> Path:
    """Fill `folder`'s file system, then give `free_pages` pages back; returns the filler."""
    filler = folder / "filler"
    fd = os.open(filler, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    try:
        while True:
            os.write(fd, b"x" * PAGE)
    except OSError:
        pass
    size = os.fstat(fd).st_size
    os.ftruncate(fd, max(0, size - PAGE * free_pages))
    os.close(fd)
    return filler


def _rows(path: Path) -> str:
    return outputs.strip_wall_clock(path.read_text())


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """The folder of the tiny run, written where nothing fails."""
    out = tmp_path_factory.mktemp("reference") / "run"
    proc = _run("run", *TINY, "--out", out)
    assert proc.returncode == 0, proc.stderr
    return out


# --------------------------------------------------------------------------- unusable outputs


def test_an_output_under_proc_is_refused_before_the_episode(tmp_path):
    start = time.monotonic()
    proc = _run("run", *TINY, "--out", "/proc/sortsim-nothing-lost")
    assert proc.returncode == 2
    line = _one_line(proc.stderr)
    assert line.startswith("sortsim run: --out") and "/proc/sortsim-nothing-lost" in line
    assert time.monotonic() - start < 30  # refused before the episode


def test_a_read_only_file_system_is_refused_before_the_episode(tmp_path):
    with _tmpfs(tmp_path / "ro", "64k", read_only=True) as ro:
        proc = _run("run", *TINY, "--out", ro / "run")
        assert proc.returncode == 2
        line = _one_line(proc.stderr)
        assert line.startswith("sortsim run: --out") and str(ro) in line
        proc = _run("run", *TINY, "--out", tmp_path / "ok", "--video", ro / "v.mp4")
        assert proc.returncode == 2 and "--video" in _one_line(proc.stderr)
        assert not (tmp_path / "ok").exists()


def test_a_full_disk_is_refused_before_the_episode(tmp_path):
    with _tmpfs(tmp_path / "full", "64k") as full:
        _fill(full, 0)
        proc = _run("run", *TINY, "--out", full / "run")
        assert proc.returncode == 2
        assert "No space left on device" in _one_line(proc.stderr)
        assert sorted(p.name for p in full.iterdir()) == ["filler"]  # the probe left nothing


def test_a_disk_that_fills_during_the_run_keeps_the_results_elsewhere(tmp_path, reference):
    with _tmpfs(tmp_path / "small", "200k") as small:
        _fill(small, 1)  # the probe's page: room for it, not for the three files
        proc = _run("run", *TINY, "--out", small / "run")
        assert proc.returncode == 1
        line = _one_line(proc.stderr)
        assert "No space left on device" in line and "kept in" in line
        kept = Path(line.split("kept in ", 1)[1].split(" ", 1)[0])
        # Nothing half-written in the folder: no CSV, no temporary, no lock file.
        assert list((small / "run").iterdir()) == []
    record = json.loads(kept.read_text())
    assert record["folder"] == str(small / "run")
    restored = outputs.restore_unwritten(kept, tmp_path / "restored")
    kept.unlink()
    names = ["episodes.csv", "picks.csv", "timeline.csv", "manifest.json"]
    assert [p.name for p in restored] == names
    for name in ("episodes.csv", "picks.csv", "timeline.csv"):
        assert _rows(tmp_path / "restored" / name) == _rows(reference / name)
    manifest = json.loads((tmp_path / "restored" / "manifest.json").read_text())
    assert set(manifest["files"]) == {"episodes.csv", "picks.csv", "timeline.csv"}


def test_files_land_together_or_not_at_all(tmp_path, monkeypatch):
    folder = tmp_path / "run"
    outputs.write_together(folder, {"a.csv": "old a\n", "manifest.json": "{}\n"})
    real = outputs._write_synced

    def full_at_the_manifest(path, data):
        if "manifest" in path.name:
            raise OSError(28, "No space left on device", str(path))
        real(path, data)

    monkeypatch.setattr(outputs, "_write_synced", full_at_the_manifest)
    with pytest.raises(OSError):
        outputs.write_together(folder, {"a.csv": "new a\n", "manifest.json": '{"new": 1}\n'})
    assert (folder / "a.csv").read_text() == "old a\n"  # the earlier run's files untouched
    assert sorted(p.name for p in folder.iterdir()) == ["a.csv", "manifest.json"]


def test_a_failing_video_never_costs_the_csvs(tmp_path, reference):
    with _tmpfs(tmp_path / "videos", "64k") as videos:
        proc = _run("run", *TINY, "--out", tmp_path / "run", "--video", videos / "v.mp4")
        assert proc.returncode == 1
        line = _one_line(proc.stderr)
        assert line.startswith("sortsim run: error: the video") and "written in" in line
        assert list(videos.iterdir()) == []  # the cut MP4 removed, no temporary left
    for name in ("episodes.csv", "picks.csv"):
        assert _rows(tmp_path / "run" / name) == _rows(reference / name)
    assert (tmp_path / "run" / "manifest.json").exists()


def test_a_sweep_whose_disk_fills_stops_in_one_line_and_resumes(tmp_path):
    config = tmp_path / "sweep.toml"
    config.write_text(SWEEP.format(items=5, seeds=2, duration=3.0))
    reference = tmp_path / "reference"
    assert _run("sweep", "--config", config, "--out", reference, "--workers", "1").returncode == 0
    with _tmpfs(tmp_path / "disk", "400k") as disk:
        out = disk / "sweep"
        proc = _start("sweep", "--config", config, "--out", out, "--workers", "1", "--quiet")
        _wait_for(lambda: len(outputs.read_rows(out / "episodes.csv")) >= 1, proc)
        filler = _fill(disk, 0)
        proc.wait(timeout=300)
        assert proc.returncode == 1
        line = _one_line(proc.stderr.read())
        assert "No space left on device" in line and "run the same command again" in line
        before = (out / "episodes.csv").read_text()
        done = outputs.read_rows(out / "episodes.csv")
        assert 1 <= len(done) < 4
        assert len(outputs.read_rows(out / "picks.csv")) >= 1  # readable, whole
        filler.unlink()
        again = _run("sweep", "--config", config, "--out", out, "--workers", "1")
        assert again.returncode == 0, again.stderr
        after = (out / "episodes.csv").read_text()
        for row in before.splitlines()[1:]:  # the rows of before, kept as they were
            assert row in after.splitlines()
        assert _rows(out / "episodes.csv") == _rows(reference / "episodes.csv")
        assert _rows(out / "picks.csv") == _rows(reference / "picks.csv")


# ------------------------------------------------------------------------------ folders in use


def test_a_held_lock_refuses_a_second_holder(tmp_path):
    with FolderLock(tmp_path / "out") as first:
        assert (tmp_path / "out" / LOCK_FILE).exists()
        with pytest.raises(outputs.InvalidInput) as refused:
            FolderLock(tmp_path / "out").acquire()
        assert str(os.getpid()) in str(refused.value) and str(tmp_path / "out") in str(
            refused.value
        )
        assert first.held
    assert not (tmp_path / "out" / LOCK_FILE).exists()  # let go: the file is gone
    with FolderLock(tmp_path / "out"):  # and it can be taken again
        pass


def test_two_runs_into_one_folder_one_runs_the_other_is_refused(tmp_path):
    out = tmp_path / "run"
    first = _start("run", *LONGER, "--seed", "4", "--out", out)
    _wait_for(lambda: (out / LOCK_FILE).exists(), first)
    second = _run("run", *TINY, "--seed", "9", "--out", out)
    assert second.returncode == 2
    line = _one_line(second.stderr)
    assert f"{out} is in use by process {first.pid}" in line
    assert first.wait(timeout=300) == 0, first.stderr.read()
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["seeds"] == [4] and manifest["config"]["items"] == 60
    assert {r["seed"] for r in outputs.read_rows(out / "episodes.csv")} == {"4"}
    assert not (out / LOCK_FILE).exists()


def test_two_sweeps_into_one_folder_one_runs_the_other_is_refused(tmp_path):
    config = tmp_path / "sweep.toml"
    config.write_text(SWEEP.format(items=20, seeds=4, duration=10.0))  # seconds after its lock
    out = tmp_path / "sweep"
    first = _start("sweep", "--config", config, "--out", out, "--workers", "1", "--quiet")
    _wait_for(lambda: (out / LOCK_FILE).exists(), first)
    second = _run("sweep", "--config", config, "--out", out, "--workers", "1")
    assert second.returncode == 2
    assert f"{out} is in use by process {first.pid}" in _one_line(second.stderr)
    assert first.wait(timeout=300) == 0, first.stderr.read()
    keys = [(r["planner"], r["seed"]) for r in outputs.read_rows(out / "episodes.csv")]
    assert len(keys) == len(set(keys)) == 8  # every episode once, none twice


def test_a_run_and_a_sweep_never_share_a_folder(tmp_path, reference):
    config = tmp_path / "sweep.toml"
    config.write_text(SWEEP.format(items=5, seeds=1, duration=3.0))
    run_dir = tmp_path / "run"
    shutil.copytree(reference, run_dir)
    proc = _run("sweep", "--config", config, "--out", run_dir)
    assert proc.returncode == 2 and "not a run's" in _one_line(proc.stderr)
    sweep_dir = tmp_path / "sweep"
    sweep_dir.mkdir()
    (sweep_dir / "sweep.json").write_text('{"sweep": "x", "identity": "y"}\n')
    proc = _run("run", *TINY, "--out", sweep_dir)
    assert proc.returncode == 2 and "not a sweep's" in _one_line(proc.stderr)


def test_a_lock_file_left_by_a_killed_run_breaks_nothing(tmp_path, reference):
    out = tmp_path / "run"
    shutil.copytree(reference, out)
    (out / LOCK_FILE).write_text("999999\n")  # as a kill -9 leaves it
    report = _run("report", out, "--out", tmp_path / "report")
    assert report.returncode == 0, report.stderr
    assert _run("run", *TINY, "--out", out).returncode == 0  # the stale file is no lock


# ------------------------------------------------------------------------ a sweep's workers


def _workers(pid: int) -> list[int]:
    proc = subprocess.run(["pgrep", "-P", str(pid), "-f", "spawn_main"], capture_output=True)
    return [int(p) for p in proc.stdout.split()]


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split()[2] != "Z"
    except OSError:
        return False


@pytest.fixture
def long_sweep(tmp_path):
    if shutil.which("pgrep") is None or not Path("/proc").is_dir():
        pytest.skip("needs pgrep and /proc to see the sweep's workers")
    config = tmp_path / "sweep.toml"
    # 40 episodes of a few seconds each: the sweep is still running when the test stops it,
    # however fast the machine (4 of them ended before the signal on a quiet one).
    config.write_text(SWEEP.format(items=60, seeds=20, duration=30.0))
    proc = subprocess.Popen(
        _command("sweep", "--config", config, "--out", tmp_path / "out", "--workers", "2"),
        cwd=REPO_ROOT,
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's job
        # and Ctrl-C's default action, as a terminal's job has it, however the suite was started
        # (a shell starts a background job with SIGINT ignored, and children inherit that)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    _wait_for(lambda: len(_workers(proc.pid)) == 2, proc)
    workers = _workers(proc.pid)
    time.sleep(5.0)  # the workers import and start their first episodes
    yield proc, workers
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)


def test_ctrl_c_on_a_sweep_prints_one_line_and_no_worker_traceback(long_sweep):
    proc, workers = long_sweep
    os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C on a terminal sends: the whole group
    assert proc.wait(timeout=60) == 130
    stderr = proc.stderr.read()
    assert "SpawnPoolWorker" not in stderr and "Traceback" not in stderr, stderr
    assert stderr.strip().splitlines()[-1] == "sortsim sweep: interrupted"
    end = time.monotonic() + 10
    while any(_alive(w) for w in workers) and time.monotonic() < end:
        time.sleep(0.05)
    assert not any(_alive(w) for w in workers)


def test_the_workers_of_a_killed_sweep_end_at_once(long_sweep):
    proc, workers = long_sweep
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    start = time.monotonic()
    while any(_alive(w) for w in workers) and time.monotonic() - start < 30:
        time.sleep(0.02)
    assert not any(_alive(w) for w in workers)
    assert time.monotonic() - start < 2.0  # not after their 30 s episodes


def test_a_storage_error_anywhere_ends_in_one_line(monkeypatch, capfd):
    import errno

    from sim.cli import cycle
    from sim.cli import main as cli

    def full(args):
        raise OSError(errno.ENOSPC, "No space left on device", "/mnt/full/x.json")

    monkeypatch.setattr(cycle, "main", full)
    assert cli.main(["cycle"]) == 1
    err = capfd.readouterr().err
    assert err == "sortsim cycle: error: No space left on device: /mnt/full/x.json\n"
    monkeypatch.setattr(cycle, "main", lambda args: open("/nonexistent/dir/x"))  # a bug's
    with pytest.raises(FileNotFoundError):  # an error of the code keeps its traceback
        cli.main(["cycle"])
