"""The closed loop in physics: a short truth-mode episode picks items into bins, deterministic."""

from __future__ import annotations

import subprocess
import sys

import pytest

from sim import config
from sim.episode.runner import run_episode
from sim.results import outputs

SHORT = dict(items=8, duration_s=6.0, perception="truth", planner="proximity", seed=3)


@pytest.fixture(scope="module")
def short_run(cell):
    return run_episode(config.load(None, **SHORT), cell=cell)


def test_items_are_picked_into_their_bins(short_run):
    row = short_run.episode_row
    assert row["entered"] == 8
    assert row["picked"] >= 4, row
    assert row["picked"] - row["wrong_bin"] >= 4
    accounted = row["picked"] + row["missed"] + row["dropped"]
    assert accounted == row["entered"], row
    assert row["accuracy"] == pytest.approx(row["picked"] / row["entered"])
    assert 0.2 < row["mean_cycle_s"] < 5.0
    assert row["profit_eur"] > 0.0


def test_picks_rows_match_the_episode(short_run):
    picks = short_run.pick_rows
    assert len(picks) == short_run.episode_row["attempts"] >= short_run.episode_row["picked"]
    successes = [p for p in picks if p["success"]]
    assert len(successes) >= short_run.episode_row["picked"] - 1
    for p in picks:
        assert p["t_end_s"] > p["t_start_s"]
        assert p["bin"] in ("paper", "plastic", "aluminium")
        assert p["predicted_class"] == p["bin"]  # truth mode: certain classes
    starts = [p["t_start_s"] for p in picks]
    assert starts == sorted(starts)


def test_profit_counts_only_items_in_their_own_bin(short_run):
    row, config = short_run.episode_row, short_run.config
    paper, plastic, aluminium = config.values.of_materials(config.materials)
    top = row["picked_paper"] * paper + row["picked_plastic"] * plastic
    top += row["picked_aluminium"] * aluminium
    assert row["profit_eur"] <= top + 1e-9
    if row["wrong_bin"] == 0:
        assert row["profit_eur"] == pytest.approx(top)


def test_same_seed_same_bytes_on_a_reused_cell(cell, short_run, tmp_path):
    again = run_episode(config.load(None, **SHORT), cell=cell)
    a = outputs.to_csv_text(outputs.EPISODE_COLUMNS, [short_run.episode_row])
    b = outputs.to_csv_text(outputs.EPISODE_COLUMNS, [again.episode_row])
    assert outputs.strip_wall_clock(a) == outputs.strip_wall_clock(b)
    pa = outputs.to_csv_text(outputs.PICK_COLUMNS, short_run.pick_rows)
    assert pa == outputs.to_csv_text(outputs.PICK_COLUMNS, again.pick_rows)


def test_another_seed_gives_another_flow(cell, short_run):
    other = run_episode(config.load(None, **{**SHORT, "seed": 4}), cell=cell)
    assert other.pick_rows != short_run.pick_rows


_CHILD = """
import sys
from sim import config
from sim.results import outputs
from sim.episode.runner import run_episode
c = config.load(None, items=5, duration_s=4.0, perception="truth", planner="qlearning", seed=11)
r = run_episode(c)
text = outputs.to_csv_text(outputs.EPISODE_COLUMNS, [r.episode_row])
sys.stdout.write(outputs.strip_wall_clock(text))
sys.stdout.write(outputs.to_csv_text(outputs.PICK_COLUMNS, r.pick_rows))
"""


def test_two_processes_give_byte_identical_csvs():
    runs = [
        subprocess.run([sys.executable, "-c", _CHILD], capture_output=True, text=True, timeout=300)
        for _ in range(2)
    ]
    for r in runs:
        assert r.returncode == 0, r.stderr
    assert runs[0].stdout == runs[1].stdout
    assert "qlearning" in runs[0].stdout


@pytest.mark.slow
def test_camera_episode_sees_and_picks_items(cell):
    result = run_episode(
        config.load(None, items=6, duration_s=5.0, perception="camera", planner="qlearning"),
        cell=cell,
    )
    row = result.episode_row
    assert row["entered"] == 6
    assert row["attempts"] >= 2, row
    assert row["picked"] >= 1, row
    assert result.latencies["perception"], "no frame went through the camera pipeline"
    assert row["min_class_confidence"] == 0.9  # unset: the fused classifier's own threshold
    assert 0 <= row["left_unsure"] <= row["entered"]
