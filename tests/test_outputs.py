"""Output files: the contract's columns, fixed formatting, atomic writes and appends."""

from __future__ import annotations

import os

import pytest

from sim.results import outputs

DESIGN_EPISODE_COLUMNS = (
    "seed, planner, speed_factor, belt_speed_mps, n_items, picked, picked_paper, picked_plastic, "
    "picked_aluminium, wrong_bin, missed, accuracy, profit_eur, mean_cycle_s, sim_s, wall_s"
).split(", ")
DESIGN_PICK_COLUMNS = (
    "t_start_s, t_end_s, item_id, true_class, predicted_class, bin, success, cycle_s"
).split(", ")


def test_columns_contain_the_contract():
    assert list(outputs.EPISODE_COLUMNS[: len(DESIGN_EPISODE_COLUMNS)]) == DESIGN_EPISODE_COLUMNS
    assert list(outputs.PICK_COLUMNS[: len(DESIGN_PICK_COLUMNS)]) == DESIGN_PICK_COLUMNS


def test_fixed_float_formatting_is_stable():
    assert outputs.format_value("accuracy", 0.1 + 0.2) == "0.3000"
    assert outputs.format_value("belt_speed_mps", 0.185 * 1.2) == "0.2220"
    assert outputs.format_value("success", True) == "1"
    assert outputs.format_value("planner", "qlearning") == "qlearning"


def test_write_is_atomic_and_leaves_no_temporary_files(tmp_path):
    path = tmp_path / "sub" / "picks.csv"
    row = {"t_start_s": 1.0, "t_end_s": 1.5, "item_id": 3, "success": True, "cycle_s": 0.5}
    outputs.write_picks(path, [row])
    first = path.read_bytes()
    assert first.startswith(b"t_start_s,t_end_s,item_id")
    assert b"1.0000,1.5000,3,,,,1,0.5000,,,,\n" in first
    outputs.write_picks(path, [row, row])
    assert path.read_bytes().count(b"\n") == 3
    assert os.listdir(path.parent) == ["picks.csv"]


def test_failed_write_keeps_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "episodes.csv"
    outputs.write_episodes(path, [{"seed": 1}])
    before = path.read_bytes()

    def boom(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(outputs.os, "replace", boom)
    with pytest.raises(OSError):
        outputs.write_episodes(path, [{"seed": 2}])
    assert path.read_bytes() == before
    assert os.listdir(tmp_path) == ["episodes.csv"]


def test_append_keeps_earlier_rows_byte_for_byte(tmp_path):
    path = tmp_path / "episodes.csv"
    outputs.append_episode(path, {"seed": 0, "accuracy": 0.5, "wall_s": 1.23456})
    first = path.read_text()
    outputs.append_episode(path, {"seed": 1, "accuracy": 2 / 3, "wall_s": 9.0})
    text = path.read_text()
    assert text.startswith(first)
    rows = outputs.read_rows(path)
    assert [r["seed"] for r in rows] == ["0", "1"] and rows[1]["accuracy"] == "0.6667"
    stripped = outputs.strip_wall_clock(text)
    assert "wall_s" not in stripped and "1.235" not in stripped
