"""The planner comparison over sweep folders: means, margins, seeds won, one profit per episode."""

from __future__ import annotations

import pytest

from sim.errors import InvalidInput
from sim.experiments.planner_table import read_episodes, table

HEADER = "seed,planner,speed_factor,n_items,picked,profit_eur\n"


def _write(folder, rows):
    folder.mkdir()
    (folder / "episodes.csv").write_text(HEADER + "".join(rows))
    return folder


def test_margins_and_seed_counts(tmp_path):
    a = _write(
        tmp_path / "a",
        ["0,lookahead,1.000,300,200,50.00\n", "1,lookahead,1.000,300,201,51.00\n"],
    )
    b = _write(
        tmp_path / "b",
        [
            "0,fifo,1.000,300,190,49.00\n",
            "1,fifo,1.000,300,205,51.00\n",
            "0,lookahead,1.000,300,200,50.00\n",  # the same episode again: counted once
        ],
    )
    text = table(read_episodes([a, b]), "lookahead")
    assert "| x1 | 300 | 50.50 (200.5, n=2) | 50.00 (197.5, n=2) |" in text
    assert "| x1 | 300 | fifo | +0.50 | 1 / 1 / 0 |" in text
    assert text.endswith("every planner: True")


def test_no_comparison_is_not_a_win(tmp_path):
    a = _write(tmp_path / "a", ["0,lookahead,1.000,300,200,50.00\n"])
    assert table(read_episodes([a]), "lookahead").endswith("every planner: False")


def test_two_profits_for_one_episode_are_refused(tmp_path):
    a = _write(tmp_path / "a", ["0,fifo,1.000,300,190,49.00\n"])
    b = _write(tmp_path / "b", ["0,fifo,1.000,300,190,48.00\n"])
    with pytest.raises(InvalidInput, match="one profit per episode"):
        read_episodes([a, b])
    with pytest.raises(InvalidInput, match="episodes.csv"):
        read_episodes([tmp_path / "missing"])
