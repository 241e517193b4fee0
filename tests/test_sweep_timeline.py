"""A sweep's timeline.csv: every episode's timeline rows led by its key columns, written with its
row in episodes.csv, never twice after a resume, never lost by an interruption."""

from __future__ import annotations

import shutil

import pytest

from sim.experiments import sweep_config
from sim.experiments import sweep_runner as sweep
from sim.results import outputs, timeline

GRID = """
[sweep]
name = "tiny_timeline"
speed_factors = [1.0]
items = [3]
planners = ["proximity"]
seeds = 1

[base]
perception = "truth"
duration_s = 3.0

[[variants]]
name = "every second"
timeline = { period_s = 1.0 }

[[variants]]
name = "every 1.5 s"
timeline = { period_s = 1.5 }
"""
KEY = ("variant", "planner", "speed_factor", "n_items", "seed", "variant.timeline.period_s")


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """(config, folder) of a real sweep of two tiny episodes, one per timeline period."""
    root = tmp_path_factory.mktemp("sweep_timeline")
    (root / "grid.toml").write_text(GRID)
    config = sweep_config.load(root / "grid.toml")
    sweep.run_sweep(config, root / "out", workers=1)
    return config, root / "out"


def _by_episode(out) -> dict[str, list[dict]]:
    steps: dict[str, list[dict]] = {}
    for row in outputs.read_rows(out / sweep.TIMELINE_FILE):
        steps.setdefault(sweep.row_key(row), []).append(row)
    return steps


def test_each_episode_has_its_rows_led_by_its_key_columns(swept):
    config, out = swept
    header = (out / sweep.TIMELINE_FILE).read_text().splitlines()[0].split(",")
    assert tuple(header) == KEY + timeline.timeline_columns(1)
    assert tuple(header) == sweep.timeline_columns(config)
    episodes = outputs.read_rows(out / "episodes.csv")
    steps = _by_episode(out)
    assert list(steps) == [sweep.row_key(r) for r in episodes] == [s.key for s in config.episodes]
    for row in episodes:
        mine = steps[sweep.row_key(row)]
        period = float(row["variant.timeline.period_s"])
        times = [float(s["t_s"]) for s in mine]
        assert len(mine) == int(float(row["sim_s"]) // period) + 1  # every period, then the end
        assert times[:-1] == pytest.approx([period * (k + 1) for k in range(len(times) - 1)])
        assert times[-1] == pytest.approx(float(row["sim_s"]), abs=1e-3)
        last = mine[-1]
        for column in ("entered", "picked", "missed", "dropped", "wrong_bin"):
            assert last[column] == row[column]
        assert float(last["profit_eur"]) == pytest.approx(float(row["profit_eur"]), abs=1e-4)
        assert all(s["variant.timeline.period_s"] == row["variant.timeline.period_s"] for s in mine)


def test_a_resumed_sweep_neither_repeats_nor_loses_an_episodes_rows(swept, tmp_path):
    """Killed after the second episode's timeline was written but before its row: the start
    drops those rows, the episode runs again, and the file is the uninterrupted one's."""
    config, out = swept
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    rows = outputs.read_rows(copy / "episodes.csv")
    outputs.write_episodes(copy / "episodes.csv", rows[:1], sweep.episode_columns(config))
    sweep._start(config, copy)
    assert set(_by_episode(copy)) == {sweep.row_key(rows[0])}
    sweep.run_sweep(config, copy, workers=1)
    assert (copy / sweep.TIMELINE_FILE).read_bytes() == (out / sweep.TIMELINE_FILE).read_bytes()
    sweep.run_sweep(config, copy, workers=1)  # nothing pending: nothing added
    assert (copy / sweep.TIMELINE_FILE).read_bytes() == (out / sweep.TIMELINE_FILE).read_bytes()


def test_an_interrupted_sweep_leaves_whole_rows_and_resumes(swept, tmp_path, monkeypatch):
    """Ctrl-C while the second episode runs: the first episode's rows are whole in all three
    files, no temporary is left, and the resumed sweep gives the uninterrupted timeline."""
    config, out = swept
    real = sweep.run_spec

    def stopped_second(spec):
        if spec.key == config.episodes[1].key:
            raise KeyboardInterrupt
        return real(spec)

    monkeypatch.setattr(sweep, "run_spec", stopped_second)
    with pytest.raises(KeyboardInterrupt):
        sweep.run_sweep(config, tmp_path, workers=1)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "episodes.csv",
        "picks.csv",
        sweep.IDENTITY_FILE,
        sweep.TIMELINE_FILE,
    ]
    episodes = outputs.read_rows(tmp_path / "episodes.csv")  # refuses a row of missing cells
    assert [sweep.row_key(r) for r in episodes] == [config.episodes[0].key]
    assert list(_by_episode(tmp_path)) == [config.episodes[0].key]
    monkeypatch.setattr(sweep, "run_spec", real)
    sweep.run_sweep(config, tmp_path, workers=1)
    assert (tmp_path / sweep.TIMELINE_FILE).read_bytes() == (out / sweep.TIMELINE_FILE).read_bytes()


def _rows(seed: str, picked: list[int], faults: list[str], period: float = 30.0) -> list[dict]:
    return [
        {"variant": "base", "planner": "fifo", "speed_factor": "1.000", "n_items": "9",
         "seed": seed, "t_s": f"{period * (k + 1):.3f}", "picked": str(n),
         "profit_eur": f"{0.25 * n:.4f}", "faults": f}
        for k, (n, f) in enumerate(zip(picked, faults, strict=True))
    ]  # fmt: skip


def test_the_figure_of_a_grid_point_is_the_mean_and_range_of_its_seeds():
    """Picks per minute over the last minute (from t = 0 for the first rows), the profit's
    mean, lowest and highest seed, the share of the seeds with a fault of each kind."""
    from sim.experiments.reporting import sweep_timeline as figure

    one = _rows("1", [3, 6, 12, 12], ["", "robot_stop 1", "robot_stop 1", ""])
    two = _rows("2", [1, 4, 4, 10, 11], ["", "", "belt_stop", "", ""])  # one row longer
    assert figure.recent_rates(one) == pytest.approx([6.0, 6.0, 9.0, 6.0])
    (point, seeds), *others = figure.by_point(one + two).items()
    assert not others and point == ("base", "fifo", "1.000", "9") and list(seeds) == ["1", "2"]
    timeline = figure.point_timeline(seeds)
    assert timeline.minutes == pytest.approx([0.5, 1.0, 1.5, 2.0])  # the times both sampled
    assert timeline.seeds == 2
    assert timeline.rate.mean == pytest.approx([4.0, 5.0, 6.0, 6.0])  # seed 2: 2, 4, 3, 6
    assert timeline.profit.low == pytest.approx([0.25, 1.0, 1.0, 2.5])
    assert timeline.profit.high == pytest.approx([0.75, 1.5, 3.0, 3.0])
    assert timeline.fault_share == {
        "robot_stop": [0.0, 0.5, 0.5, 0.0],
        "belt_stop": [0.0, 0.0, 0.5, 0.0],
    }


def test_the_report_of_a_sweep_draws_each_grid_points_timeline(swept, tmp_path):
    from sim.experiments.report import write_report

    _, out = swept
    written = {p.name for p in write_report([out], tmp_path / "report")}
    figures = {"timeline_every_second.png", "timeline_every_1_5_s.png", "timeline_profit.png"}
    assert figures <= written
    for name in figures:
        assert (tmp_path / "report" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "timeline_every_second.png" in (tmp_path / "report" / "report.md").read_text()


def test_the_shift_sweep_pairs_random_faults_with_none_on_the_same_seeds():
    """experiments/shift.toml: the same seeds' hours with the random faults and without them
    (their own random stream: the flows are the same), as shift_hour.toml runs one of them."""
    from pathlib import Path

    from sim import config as episode_config

    root = Path(__file__).resolve().parents[1] / "experiments"
    shift = sweep_config.load(root / "shift.toml")
    by_variant: dict[str, list] = {}
    for spec in shift.episodes:
        by_variant.setdefault(spec.variant, []).append(spec.config)
    faulty, plain = by_variant["random faults"], by_variant["no faults"]
    assert [c.seed for c in faulty] == [c.seed for c in plain] == [900, 901, 902]
    assert all(c.duration_s == c.horizon_s == 3600.0 and c.robot_count == 2 for c in faulty)
    assert all(c.fault_schedule().faults for c in faulty)
    assert not any(c.fault_schedule().faults for c in plain)
    hour = episode_config.load(root / "shift_hour.toml", seed=900)
    assert hour.fault_schedule() == faulty[0].fault_schedule()
