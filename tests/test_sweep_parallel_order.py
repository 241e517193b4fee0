"""A two-worker sweep whose episodes finish out of grid order still writes its rows in grid order.

Rows are appended to `episodes.csv` as episodes finish, whichever worker ran them; the sweep
then rewrites the file in the grid's order. To make the finishing order differ from the grid's
for certain (not by the luck of the scheduler), the grid's first episode runs a decision
manager that, when its episode starts, waits until the second episode's row is in
`episodes.csv`: the second episode (on the other worker) must finish first. The progress lines
give the finishing order, which the test checks before it checks the file.
"""

from __future__ import annotations

import os
import stat

import pytest

from sim.experiments import sweep_config
from sim.experiments import sweep_runner as sweep
from sim.results import outputs

PATIENT = '''
"""A decision manager that starts its episode only once another episode's row is written."""

import time
from pathlib import Path

CSV = Path({csv!r})


class Patient:
    name = "patient"

    def reset(self):
        deadline = time.monotonic() + 240.0
        while time.monotonic() < deadline:
            if CSV.exists() and CSV.read_text(encoding="utf-8").count("\\n") >= 2:
                return  # a header and one row: the other episode has finished
            time.sleep(0.05)

    def choose(self, items, robot, context):
        return None
'''


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """(sweep config, rows returned, progress lines) of the two-worker sweep."""
    root = tmp_path_factory.mktemp("parallel")
    out = root / "out"
    (root / "patient.py").write_text(PATIENT.format(csv=str(out / "episodes.csv")))
    (root / "grid.toml").write_text(
        f"""
[sweep]
name = "out_of_order"
speed_factors = [1.5]
items = [2]
planners = ["{root / "patient.py"}:Patient", "fifo"]
seeds = [5]

[base]
perception = "truth"
duration_s = 1.0
"""
    )
    config = sweep_config.load(root / "grid.toml")
    lines: list[str] = []
    old = os.umask(0o022)
    try:
        rows = sweep.run_sweep(config, out, workers=2, progress=lines.append)
    finally:
        os.umask(old)
    return config, out, rows, lines


def finished_keys(lines: list[str]) -> list[str]:
    """Episode keys in the order their rows were appended ('[n/N] key  accuracy ...')."""
    return [line.split()[1] for line in lines if line.startswith("[")]


def test_the_second_episode_finished_first(swept):
    config, _, _, lines = swept
    first, second = (spec.key for spec in config.episodes)
    assert first.split("|")[1].endswith(":Patient") and second.split("|")[1] == "fifo"
    assert finished_keys(lines) == [second, first], lines


def test_rows_are_rewritten_in_grid_order(swept):
    config, out, rows, _ = swept
    grid = [spec.key for spec in config.episodes]
    on_disk = outputs.read_rows(out / "episodes.csv")
    assert [sweep.row_key(r) for r in on_disk] == grid
    assert [sweep.row_key(r) for r in rows] == grid
    assert rows == on_disk
    assert [r["planner"] for r in on_disk] == [config.episodes[0].config.planner, "fifo"]
    for row in on_disk:
        assert int(row["entered"]) == 2
        assert int(row["picked"]) + int(row["missed"]) + int(row["dropped"]) == 2
    assert int(on_disk[0]["picked"]) == 0  # the patient manager never picks
    steps = outputs.read_rows(out / sweep.TIMELINE_FILE)  # each episode's rows together
    assert list(dict.fromkeys(sweep.row_key(r) for r in steps)) == grid
    assert [sweep.row_key(r) for r in steps] == sorted(
        (sweep.row_key(r) for r in steps), key=grid.index
    )


def test_a_resumed_run_keeps_the_grid_order(swept):
    config, out, _, _ = swept
    before = (out / "episodes.csv").read_bytes()
    again = sweep.run_sweep(config, out, workers=2)
    assert [sweep.row_key(r) for r in again] == [spec.key for spec in config.episodes]
    assert (out / "episodes.csv").read_bytes() == before


def test_the_sweep_file_has_a_normal_mode(swept):
    _, out, _, _ = swept
    assert stat.S_IMODE((out / "episodes.csv").stat().st_mode) == 0o644


def test_a_finished_sweep_rewrites_its_picks_in_grid_order(swept, tmp_path):
    """picks.csv as appended out of grid order (a row of the grid's first episode last) is
    rewritten with every episode's picks in the grid's order, their own order kept."""
    import shutil

    config, out, _, _ = swept
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    picks = outputs.read_rows(copy / sweep.PICKS_FILE)
    assert picks, "the fifo episode picked"
    spec = config.episodes[0]  # the patient manager's episode: no picks of its own
    first = {**picks[0], "variant": spec.variant, "planner": spec.config.planner}
    appended = [*picks, {**first, "t_start_s": "0.5"}, {**first, "t_start_s": "0.25"}]
    outputs.write_sweep_picks(copy / sweep.PICKS_FILE, appended, sweep.pick_columns(config))
    sweep.run_sweep(config, copy, workers=1)
    rewritten = outputs.read_rows(copy / sweep.PICKS_FILE)
    assert [r["t_start_s"] for r in rewritten[:2]] == ["0.5", "0.25"]
    assert rewritten[2:] == picks


def test_workers_take_the_longest_flows_first(tmp_path):
    (tmp_path / "grid.toml").write_text(
        """
[sweep]
name = "lengths"
items = [10, 40, 20]
planners = ["fifo"]
seeds = [1, 2]
duration_s_by_items = { 10 = 5.0, 40 = 30.0, 20 = 30.0 }

[base]
perception = "truth"
"""
    )
    config = sweep_config.load(tmp_path / "grid.toml")
    ordered = [(s.config.items, s.config.seed) for s in sweep.dispatch_order(config.episodes)]
    assert ordered == [(40, 1), (40, 2), (20, 1), (20, 2), (10, 1), (10, 2)]
