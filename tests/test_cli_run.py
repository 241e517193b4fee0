"""`sortsim run` headless: the files (CSVs, manifest, video), the summary, refusals."""

from __future__ import annotations

import subprocess
import sys

import imageio.v2 as imageio
import numpy as np
import pytest

from sim.results import outputs
from tests.test_outputs import DESIGN_EPISODE_COLUMNS, DESIGN_PICK_COLUMNS


def _run(*args, timeout=300):
    return subprocess.run(
        [sys.executable, "-m", "sim.cli.main", "run", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    config = out / "cell.toml"
    config.write_text(
        "items = 50\nduration_s = 30.0\n[video]\nfps = 6.0\nwidth = 320\nheight = 184\n"
    )
    proc = _run(
        "--config", config, "--seed", 2, "--items", 4, "--duration", 3, "--perception", "truth",
        "--planner", "greedy", "--out", out, "--video", out / "video.mp4", "--quiet",
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return out, proc


def test_writes_the_three_files_and_a_summary(run_dir):
    out, proc = run_dir
    rows = outputs.read_rows(out / "episodes.csv")
    assert len(rows) == 1
    assert list(rows[0])[: len(DESIGN_EPISODE_COLUMNS)] == DESIGN_EPISODE_COLUMNS
    row = rows[0]
    assert (row["seed"], row["n_items"], row["planner"]) == ("2", "4", "greedy")
    assert int(row["entered"]) == 4
    picks = outputs.read_rows(out / "picks.csv")
    header = (out / "picks.csv").read_text().splitlines()[0].split(",")
    assert header[: len(DESIGN_PICK_COLUMNS)] == DESIGN_PICK_COLUMNS
    assert len(picks) == int(row["attempts"])
    assert "accuracy SP/SI" in proc.stdout and "profit" in proc.stdout
    assert len(proc.stdout.splitlines()) < 25
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == []


def test_video_decodes_with_frames_of_the_configured_size(run_dir):
    out, _ = run_dir
    reader = imageio.get_reader(out / "video.mp4")
    frames = [f for f in reader]
    meta = reader.get_meta_data()
    reader.close()
    sim_s = float(outputs.read_rows(out / "episodes.csv")[0]["sim_s"])
    assert abs(len(frames) - sim_s * 6.0) <= 3
    assert frames[0].shape == (184, 320, 3)
    assert meta["fps"] == pytest.approx(6.0)
    assert np.std(frames[len(frames) // 2]) > 10  # a rendered scene, not a blank frame
    moving = [np.abs(frames[i + 1].astype(int) - frames[i]).mean() for i in range(len(frames) - 1)]
    assert max(moving) > 1.0  # the robot and the items move


@pytest.mark.parametrize(
    ("args", "word"),
    [
        (["--items", "0"], "items"),
        (["--speed-factor", "2"], "speed_factor"),
        (["--planner", "dice"], "planner"),
        (["--perception", "lidar"], "perception"),
    ],
)
def test_bad_options_exit_2_in_one_line(tmp_path, args, word):
    proc = _run(*args, "--out", tmp_path / "o", timeout=60)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and word in lines[0] and "Traceback" not in proc.stderr
    assert not (tmp_path / "o").exists()


def test_malformed_config_names_the_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("items = \n")
    proc = _run("--config", path, "--out", tmp_path / "o", timeout=60)
    assert proc.returncode == 2
    assert str(path) in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
