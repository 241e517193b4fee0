"""Episode and sweep configs: defaults, overrides, and one-line refusals naming key and file."""

from __future__ import annotations

import subprocess
import sys

import pytest

from sim import config
from sim.errors import InvalidInput
from sim.experiments import sweep_config
from sim.paths import EXPERIMENTS_DIR


def test_defaults_are_the_headline_episode():
    c = config.load(None)
    assert (c.items, c.speed_factor, c.planner, c.perception) == (100, 1.0, "qlearning", "camera")
    assert c.belt_speed_mps == pytest.approx(0.185)
    assert c.values.by_class(c.materials) == {2: 0.22, 3: 0.25, 4: 0.27}
    assert c.materials.names == ("paper", "plastic", "aluminium") and c.catalogue == ""
    assert (c.qlearning.gamma, c.qlearning.iterations, c.qlearning.batch_rows) == (0.9, 50, 20)


def test_toml_then_command_line_overrides(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text('seed = 4\nitems = 30\nplanner = "proximity"\n[values]\naluminium = 1.5\n')
    c = config.load(path, items=12, speed_factor=1.2)
    assert (c.seed, c.items, c.planner, c.speed_factor) == (4, 12, "proximity", 1.2)
    assert c.values.of_materials(c.materials) == (0.22, 0.25, 1.5)


@pytest.mark.parametrize("factor", [1.0, 1.2, 1.5, 0.73, 1.4973])
def test_speed_factors_inside_the_conveyor_range(factor):
    assert 0.135 <= config.load(None, speed_factor=factor).belt_speed_mps <= 0.2776


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("colour = 3\n", "colour"),
        ("items = 0\n", "items"),
        ("items = 2.5\n", "items"),
        ("speed_factor = 1.6\n", "speed_factor"),
        ("speed_factor = 0.5\n", "speed_factor"),
        ('planner = "dice"\n', "planner"),
        ('perception = "lidar"\n', "perception"),
        ("[values]\npaper = -1\n", "values.paper"),
        ("[values]\nglass = 1\n", "values.glass"),
        ("[qlearning]\ngamma = 1.0\n", "qlearning.gamma"),
        ("[qlearning]\niterations = 0\n", "qlearning.iterations"),
        ("[video]\nwidth = 641\n", "video.width"),
        ("items = [\n", "config"),
    ],
)
def test_bad_toml_refused_naming_key_and_file(tmp_path, text, key):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InvalidInput) as exc:
        config.load(path)
    message = str(exc.value)
    assert message.startswith(key)
    assert str(path) in message
    assert "\n" not in message


def test_every_experiment_config_loads_and_has_its_grid():
    sizes = {
        "table_4_2": 3 * 4 * 10,
        "table_4_3": 4 * 10,
        "table_4_4": 4,
        "table_4_5": 5 * 2 * 10,
        "table_4_6": 5 * 2 * 10,
        "smoke": 4,
        "table_4_5_paused": 5 * 2 * 10,
        "table_4_6_paused": 5 * 2 * 10,
        "planners": 5 * 3,
        "line": 6 * 3 * 5,
        "line_saturated": 2 * 2 * 5,
        "line_saturated_x15": 2 * 2 * 5,
    }
    for name, size in sizes.items():
        sweep = sweep_config.load(EXPERIMENTS_DIR / f"{name}.toml")
        assert len(sweep.episodes) == size, name
        assert len({e.key for e in sweep.episodes}) == size
    t43 = sweep_config.load(EXPERIMENTS_DIR / "table_4_3.toml")
    weighted = [e for e in t43.episodes if e.variant == "weight_class_3"]
    plastic = [e.config.values.of_materials(e.config.materials)[1] for e in weighted]
    assert plastic == pytest.approx([150.25] * len(weighted))
    paused = sweep_config.load(EXPERIMENTS_DIR / "table_4_6_paused.toml")
    assert {r.pick_pause_s for e in paused.episodes for r in e.config.robots} == {0.5}
    t45 = sweep_config.load(EXPERIMENTS_DIR / "table_4_5.toml")
    assert {e.config.duration_s for e in t45.episodes if e.config.items == 400} == {191.0}


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("[sweep]\nitems = [10, 0]\n", "items"),
        ("[sweep]\nspeeds = [1.0]\n", "sweep.speeds"),
        ("[base]\nseed = 3\n", "base.seed"),
        ("[base]\ncolour = 3\n", "colour"),
        ("[extra]\n", "extra"),
        ("[sweep]\nplanners = []\n", "sweep.planners"),
    ],
)
def test_bad_sweep_refused_before_any_episode(tmp_path, text, key):
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    with pytest.raises(InvalidInput) as exc:
        sweep_config.load(path)
    assert str(exc.value).startswith(key) and str(path) in str(exc.value)


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_cli_refuses_bad_config_with_exit_2_in_one_line(tmp_path, command):
    path = tmp_path / "bad.toml"
    path.write_text("[values]\naluminium = -3\n" if command == "run" else "[sweep]\nitems = [-1]\n")
    args = [sys.executable, "-m", "sim.cli.main", command, "--config", str(path)]
    if command == "sweep":
        args += ["--out", str(tmp_path / "out")]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and "Traceback" not in proc.stderr
    assert not (tmp_path / "out").exists()
