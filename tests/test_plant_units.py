"""A plant's units where a user types: the belt's speed in m/s (`[belt] speed_mps`,
`--belt-speed`), the feed as a rate (`[infeed]`, `--items-per-m`) and a run that ends at a fixed
time (`horizon_s`, `--horizon`), counting what it leaves."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from sim import config as episode_config
from sim.cli.main import main
from sim.cli.run import add_episode_arguments, load_config
from sim.episode.loop import Episode
from sim.episode.runner import config_cell, run_episode
from sim.errors import InvalidInput
from sim.experiments import sweep_config
from sim.results import outputs


def _options(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    add_episode_arguments(parser)
    return parser.parse_args(list(argv))


def test_belt_speed_and_items_per_metre_give_the_speed_and_the_count_they_say():
    """The engineer's belt: 0.2 m/s, 18 items per metre; over the default 90 s that is 18 x
    0.2 x 90 = 324 items."""
    config = load_config(_options("--belt-speed", "0.2", "--items-per-m", "18"))
    assert config.belt_speed_mps == 0.2 and config.belt.speed_mps == 0.2
    assert config.speed_factor == pytest.approx(0.2 / 0.185, rel=1e-15)
    assert config.items == 324 and config.duration_s == 90.0
    assert config.flow_config().items_per_metre == pytest.approx(18.0, rel=1e-12)
    fed = load_config(_options("--items-per-m", "18", "--duration", "60"))  # x1: 0.185 m/s
    assert fed.items == round(18 * 0.185 * 60) == 200


def test_a_run_at_belt_speed_0_2_carries_its_items_at_0_2_m_per_s():
    """Measured from the physics: the belt's surface velocity, and the items in contact
    dynamics (`item_riding = "contact"`: none carried kinematically) moving at it."""
    config = episode_config.load(
        None,
        belt_speed_mps=0.2,
        items_per_m=18,
        duration_s=5.0,
        horizon_s=8.0,
        perception="truth",
        item_riding="contact",
    )
    assert config.items == 18  # 18 per metre x 0.2 m/s x 5 s
    cell = config_cell(config)
    samples = []

    def watch(ep):
        slots = ep.cell.items.active_slots()
        held = set(ep.held().tolist())
        free = np.array([s for s in slots if s not in held], dtype=int)
        x = ep.cell.items.positions(free)[:, 0].copy() if len(free) else np.zeros(0)
        samples.append(
            (float(ep.data.time), [int(ep.cell.items.pool.item_ids[s]) for s in free], x)
        )

    with Episode(config, cell) as episode:
        episode.every(1.0, watch)
        episode.reset()
        belt = cell.model.geom("belt").id
        assert cell.model.geom_surfacevel[belt][0] == 0.2
        episode.run()
        row = episode.metrics.row()
    assert row["entered"] + row["not_arrived"] == 18 and row["entered"] == 18
    speeds = []
    for (t0, ids0, x0), (t1, ids1, x1) in zip(samples, samples[1:], strict=False):
        for k, item in enumerate(ids0):
            if item in ids1 and -2.5 < x0[k] < -1.2:  # settled, upstream of the robot's reach
                speeds.append((x1[ids1.index(item)] - x0[k]) / (t1 - t0))
    assert len(speeds) >= 10
    assert np.median(speeds) == pytest.approx(0.2, abs=0.002)


def test_the_horizon_ends_the_run_at_its_time_and_the_counts_add_up():
    """15 s into a 20 s feed: the items on the belt (one in the cup of a pick cut short) and
    those not yet dropped are counted, and every accounting identity holds."""
    config = episode_config.load(
        None, perception="truth", items=30, duration_s=20.0, horizon_s=15.0
    )
    with Episode(config, config_cell(config)) as episode:
        episode.reset()
        episode.run()
        metrics, end = episode.metrics, float(episode.data.time)
        cut_short = any(s.robot.busy for s in episode.parts.stations)
    assert end == pytest.approx(15.0, abs=1e-9)
    assert cut_short  # a pick was under way at the horizon: its item counts as left
    row = metrics.row()
    assert row["left_on_belt"] > 0 and row["not_arrived"] > 0
    assert row["entered"] + row["not_arrived"] == 30
    assert row["entered"] == row["picked"] + row["missed"] + row["dropped"] + row["left_on_belt"]
    assert metrics.accounting_failures() == []


def test_without_a_horizon_nothing_is_left_and_everything_arrives():
    config = episode_config.load(None, perception="truth", items=4, duration_s=3.0)
    row = run_episode(config).episode_row
    assert row["left_on_belt"] == 0 and row["not_arrived"] == 0
    assert row["entered"] == 4 == row["picked"] + row["missed"] + row["dropped"]


def test_sortsim_run_writes_the_horizon_columns_and_its_manifest_repeats_the_run(tmp_path):
    out = tmp_path / "run"
    argv = ["run", "-q", "--perception", "truth", "--belt-speed", "0.25", "--items-per-m", "6"]
    argv += ["--duration", "4", "--horizon", "10", "--out", str(out)]
    assert main(argv) == 0
    row = outputs.read_rows(out / "episodes.csv")[0]
    assert row["belt_speed_mps"] == "0.2500" and row["n_items"] == "6"  # 6 x 0.25 x 4
    assert row["items_per_m"] == "6.000" and row["sim_s"] == "10.000"
    assert int(row["left_on_belt"]) + int(row["picked"]) + int(row["missed"]) == 6
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["config"]["belt"]["speed_mps"] == 0.25
    assert manifest["config"]["infeed"]["items_per_m"] == 6.0
    assert "speed_factor" not in manifest["config"] and "items" not in manifest["config"]
    again = tmp_path / "again"
    assert main(["run", "-q", "--config", str(out / "manifest.json"), "--out", str(again)]) == 0
    assert (again / "episodes.csv").read_text().splitlines()[1].split(",")[:6] == (
        (out / "episodes.csv").read_text().splitlines()[1].split(",")[:6]
    )
    # An option in one unit replaces the file's in the other; one the feed depends on works
    # the count out again.
    faster = episode_config.load(out / "manifest.json", speed_factor=1.5, items=10)
    assert faster.belt.speed_mps is None and faster.belt_speed_mps == pytest.approx(0.2775)
    assert faster.infeed.rate is None and faster.items == 10
    longer = episode_config.load(out / "manifest.json", duration_s=60.0, belt_speed_mps=0.2)
    assert longer.items == 72 and longer.belt_speed_mps == 0.2  # 6 x 0.2 x 60


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--belt-speed", "0.2", "--speed-factor", "1.2"], "--belt-speed: allowed one of"),
        (["--items", "50", "--items-per-m", "18"], "--items-per-m: allowed one of"),
        (["--belt-speed", "0.3"], "belt.speed_mps: allowed 0.135..0.277 m/s"),
        (["--items-per-m", "31"], "infeed.items_per_m: allowed 0.01..30 items per metre"),
        (["--horizon", "0"], "horizon_s: allowed 1..36000 s"),
    ],
)
def test_both_units_at_once_or_a_value_out_of_range_exits_2_in_one_line(
    tmp_path, capsys, argv, words
):
    out = tmp_path / "out"
    assert main(["run", "--perception", "truth", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1, err
    assert not out.exists()


@pytest.mark.parametrize(
    ("text", "field", "words"),
    [
        ("speed_factor = 1.2\n[belt]\nspeed_mps = 0.2\n", "speed_factor", "0.2 m/s is x1.081"),
        ("speed_factor = 1.0\n[belt]\nspeed_mps = 0.2\n", "speed_factor", "unset when"),
        ("items = 100\n[infeed]\nitems_per_m = 18.0\n", "items", "18 gives 300 items"),
        ("items = 300\n[infeed]\nitems_per_m = 18.0\n", "items", "unset when"),
        ("[infeed]\nitems_per_m = 18.0\nkg_per_h = 250.0\n", "infeed", "not several"),
        ("[infeed]\nitems_per_s = 6.0\n", "infeed.items_per_s", "5.55 items/s at 0.185 m/s"),
        ("[infeed]\nkg_per_h = 1000.0\n", "infeed.kg_per_h", "at most 30 items per metre"),
        ("duration_s = 1.0\n[infeed]\nitems_per_m = 0.5\n", "infeed.items_per_m", "1..20000"),
    ],
)
def test_a_config_file_giving_one_thing_twice_is_refused_naming_key_and_file(
    tmp_path, text, field, words
):
    path = tmp_path / "plant.toml"
    path.write_text(text)
    with pytest.raises(InvalidInput) as refused:
        episode_config.load(path)
    assert refused.value.field == field and words in str(refused.value), str(refused.value)
    assert refused.value.where == str(path)


def test_a_feed_in_kilograms_per_hour_counts_items_at_the_mean_item_mass():
    config = episode_config.from_dict({"infeed": {"kg_per_h": 250.0}, "duration_s": 360.0})
    mass = config.mean_item_mass_kg
    assert 0.015 < mass < 0.025
    assert config.items == round(250.0 / 3600.0 / mass * 360.0)
    plant = {"mix": {"paper": 0.4, "plastic": 0.35, "aluminium": 0.25}}
    mixed = episode_config.from_dict({"infeed": {"kg_per_h": 250.0}, "flow": plant})
    assert mixed.mean_item_mass_kg != mass  # the mix decides the mean mass


def test_replace_works_the_plant_units_out_again():
    config = episode_config.from_dict({"belt": {"speed_mps": 0.2}, "infeed": {"items_per_m": 18}})
    longer = config.replace(duration_s=60.0)
    assert longer.items == 216 and longer.belt_speed_mps == 0.2  # 18 x 0.2 x 60
    faster = config.replace(belt=episode_config.Belt(speed_mps=0.25))
    assert faster.speed_factor == 0.25 / 0.185 and faster.items == 405
    counted = config.replace(items=50, speed_factor=1.2)
    assert counted.infeed.rate is None and counted.belt.speed_mps is None
    assert config.replace(seed=3) == config.replace(seed=3).replace(seed=3)


def test_a_sweep_over_belt_speeds_in_m_per_s(tmp_path):
    path = tmp_path / "plant.toml"
    path.write_text(
        "[sweep]\nbelt_speeds_mps = [0.2, 0.25]\nseeds = 2\n"
        '[base]\nperception = "truth"\nduration_s = 10.0\n[base.infeed]\nitems_per_m = 18.0\n'
    )
    sweep = sweep_config.load(path)
    got = [(e.config.belt_speed_mps, e.config.items, e.config.seed) for e in sweep.episodes]
    assert got == [(0.2, 36, 0), (0.2, 36, 1), (0.25, 45, 0), (0.25, 45, 1)]
    path.write_text("[sweep]\nbelt_speeds_mps = [0.2]\nspeed_factors = [1.0]\n")
    with pytest.raises(InvalidInput, match="sweep.speed_factors"):
        sweep_config.load(path)
    path.write_text("[sweep]\nbelt_speeds_mps = [0.2]\n[base.belt]\nspeed_mps = 0.25\n")
    with pytest.raises(InvalidInput, match=r"base\.belt\.speed_mps"):
        sweep_config.load(path)
