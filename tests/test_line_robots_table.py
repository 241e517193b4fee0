"""A line's `[[robots]]` table: each robot's position, the materials it sorts and its pauses,
from the config to the compiled model and the episode, refused in one line naming the field,
and kept by a run's manifest; the old forms (`robots = N`, the `[robot]` section) read into the
same one tuple of robots."""

from __future__ import annotations

import json

import pytest

from sim import config as episode_config
from sim.config.robots import RobotSpec
from sim.episode.loop import Episode
from sim.episode.runner import config_cell, shared_cell
from sim.errors import InvalidInput

TABLE = """
[[robots]]
x_m = 0.0
materials = ["aluminium"]
[[robots]]
x_m = 2.2
"""
"""Robot 0 at the first robot's place sorting aluminium only, robot 1 2.2 m downstream (not the
default 1.8 m) sorting everything."""
ALUMINIUM = 4
"""The default catalogue's class id of aluminium (paper 2, plastic 3)."""


def _config(tmp_path, text: str = TABLE, **overrides) -> episode_config.EpisodeConfig:
    path = tmp_path / "line.toml"
    path.write_text(text)
    return episode_config.load(path, **overrides)


PAUSES = {"pick_pause_s": 0.0, "place_pause_s": 0.0, "idle_sleep": True}
"""A robot's keys of the old `[robot]` section at their defaults."""


def test_the_table_is_read_into_counts_positions_and_class_ids(tmp_path):
    c = _config(tmp_path)
    assert c.robot_count == 2 and c.line_cell
    assert c.robots == (RobotSpec(0.0, ("aluminium",)), RobotSpec(2.2, None))
    assert c.robot_positions_m == (0.0, 2.2)
    assert c.robot_class_ids == (frozenset({ALUMINIUM}), None)
    assert c.to_dict()["robots"] == [
        {"x_m": 0.0, "materials": ["aluminium"], **PAUSES},
        {"x_m": 2.2, **PAUSES},
    ]
    assert episode_config.from_dict(c.to_dict()) == c


def test_a_count_gives_default_robots_and_the_command_line_count_replaces_the_table(tmp_path):
    plain = episode_config.load(None, robots=3)
    assert plain.robots == (RobotSpec(),) * 3 and plain.robot_positions_m == ()
    assert plain.robot_class_ids == (None, None, None)
    assert plain.to_dict()["robots"] == [PAUSES] * 3
    assert episode_config.from_dict({"robots": 3}) == plain
    overridden = _config(tmp_path, robots=3)
    assert overridden == plain.replace(where=None)
    only_materials = _config(tmp_path, '[[robots]]\nmaterials = ["paper"]\n[[robots]]\n')
    assert only_materials.robot_positions_m == () and only_materials.robot_class_ids[0] == {2}


SECTION_AND_TABLES = """
[robot]
pick_pause_s = 0.5
idle_sleep = false
[[robots]]
place_pause_s = 0.25
[[robots]]
pick_pause_s = 0.1
idle_sleep = true
"""
"""The old `[robot]` section gives every robot its defaults; a table's own key wins."""


def test_the_robot_section_is_every_robots_default_and_a_tables_own_key_wins(tmp_path):
    c = _config(tmp_path, SECTION_AND_TABLES)
    assert c.robots == (
        RobotSpec(pick_pause_s=0.5, place_pause_s=0.25, idle_sleep=False),
        RobotSpec(pick_pause_s=0.1, idle_sleep=True),
    )
    counted = _config(tmp_path, "robots = 2\n[robot]\npick_pause_s = 0.5\n")
    assert counted.robots == (RobotSpec(pick_pause_s=0.5),) * 2
    assert episode_config.from_dict(c.to_dict()) == c  # one array of tables, read back the same
    assert "robot" not in c.to_dict()


def test_a_count_on_the_command_line_keeps_each_robots_pauses(tmp_path):
    """`--robots N`: N robots at the default spacing sorting everything, robot k keeping robot
    k's pauses (the last robot's past the last); `replace(robots=N)` does the same."""
    c = _config(tmp_path, SECTION_AND_TABLES, robots=3)
    first = RobotSpec(pick_pause_s=0.5, place_pause_s=0.25, idle_sleep=False)
    second = RobotSpec(pick_pause_s=0.1)
    assert c.robots == (first, second, second)
    assert c.replace(robots=1).robots == (first,)
    placed = _config(tmp_path, TABLE + "[robot]\nplace_pause_s = 0.5\n", robots=2)
    assert placed.robots == (RobotSpec(place_pause_s=0.5),) * 2
    assert placed.robot_positions_m == () and placed.robot_class_ids == (None, None)


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("robots = []\n", "robots"),
        ("[[robots]]\n" * 5, "robots"),
        ("robots = [1]\n", "robots[0]"),
        ("[[robots]]\ncolour = 1\n", "robots[0].colour"),
        ("[[robots]]\npick_pause_s = 2.5\n", "robots[0].pick_pause_s"),
        ("[[robots]]\n[[robots]]\nplace_pause_s = nan\n", "robots[1].place_pause_s"),
        ('[[robots]]\n[[robots]]\nidle_sleep = "no"\n', "robots[1].idle_sleep"),
        ("[robot]\npick_pause_s = -1\n[[robots]]\n", "robot.pick_pause_s"),
        ("robots = 5\n", "robots"),
        ("robots = 0\n[robot]\nidle_sleep = true\n", "robots"),
        ('[[robots]]\nx_m = "left"\n', "robots[0].x_m"),
        ("[[robots]]\nx_m = -0.5\n", "robots[0].x_m"),
        ("[[robots]]\nx_m = 16.0\n", "robots[0].x_m"),
        ("[[robots]]\nx_m = 0.0\n[[robots]]\nx_m = 1.0\n", "robots[1].x_m"),
        ("[[robots]]\nx_m = 0.0\n[[robots]]\n", "robots[1].x_m"),
        ("[[robots]]\n[[robots]]\nmaterials = []\n", "robots[1].materials"),
        ('[[robots]]\n[[robots]]\nmaterials = "paper"\n', "robots[1].materials"),
        ('[[robots]]\n[[robots]]\nmaterials = ["paper", "paper"]\n', "robots[1].materials"),
        ('[[robots]]\n[[robots]]\nmaterials = ["glass"]\n', "robots[1].materials"),
        ('[[robots]]\nmaterials = ["paper"]\n[[robots]]\nmaterials = ["plastic"]\n', "robots"),
    ],
)
def test_bad_tables_are_refused_naming_the_field_and_the_file(tmp_path, text, field):
    with pytest.raises(InvalidInput) as err:
        _config(tmp_path, text)
    assert err.value.field == field
    assert str(tmp_path / "line.toml") in str(err.value) and "allowed" in str(err.value)


def test_the_positions_reach_the_compiled_line(tmp_path):
    c = _config(tmp_path)
    cell = config_cell(c)
    bin_x = cell.data.body("r0_bin_aluminium").xpos[0]  # robot 0's, at x = 0
    for prefix, x in zip(("r0_", "r1_"), c.robot_positions_m, strict=True):
        assert cell.data.body(f"{prefix}base_link").xpos[0] == pytest.approx(x, abs=1e-12)
        assert cell.data.body(f"{prefix}bin_aluminium").xpos[0] == pytest.approx(bin_x + x)
    assert [rc.base_x for rc in cell.robots] == pytest.approx([0.0, 2.2])
    # Another placement, another model; the same placement, the same cached model.
    settings = c.cell_settings  # a line's cup (50 mm) by default
    assert shared_cell(settings, c.item_catalogue, 2, True, (0.0, 2.2)) is cell
    assert shared_cell(settings, c.item_catalogue, 2, True) is not cell


def test_a_robot_sorting_only_aluminium_picks_only_aluminium(tmp_path):
    """40 items in 15 s over two robots, truth perception: robot 0 (aluminium only) carries
    only aluminium items, robot 1 (everything) the rest of what is picked."""
    c = _config(tmp_path, perception="truth", items=40, duration_s=15.0, seed=3)
    with Episode(c, config_cell(c)) as episode:
        episode.reset()
        episode.run()
        picks = [p for p in episode.metrics.picks if p.sealed]
        row = episode.metrics.row()
    first = [p for p in picks if p.robot == 0]
    assert first, "robot 0 picked nothing"
    assert {p.true_class for p in first} == {ALUMINIUM}
    assert {p.bin for p in first if p.success} == {ALUMINIUM}
    assert {p.true_class for p in picks if p.robot == 1} - {ALUMINIUM}, "robot 1 sorts the rest"
    assert row["mujoco_warnings"] == 0


def test_a_run_repeats_its_table_from_its_manifest(tmp_path):
    from sim.cli.main import main

    config = tmp_path / "line.toml"
    config.write_text(TABLE)
    first, again = tmp_path / "first", tmp_path / "again"
    common = ["--perception", "truth", "--items", "8", "--duration", "5", "--seed", "3"]
    assert main(["run", "--config", str(config), "--out", str(first), *common, "--quiet"]) == 0
    manifest = json.loads((first / "manifest.json").read_text())
    assert manifest["config"]["robots"] == [
        {"x_m": 0.0, "materials": ["aluminium"], **PAUSES},
        {"x_m": 2.2, **PAUSES},
    ]
    assert episode_config.load(first / "manifest.json") == _config(
        tmp_path, perception="truth", items=8, duration_s=5.0, seed=3
    )
    repeat = ["run", "--config", str(first / "manifest.json"), "--out", str(again), "--quiet"]
    assert main(repeat) == 0
    assert (first / "picks.csv").read_bytes() == (again / "picks.csv").read_bytes()
