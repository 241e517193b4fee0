"""An old file's `[robot]` section is read at the edge (`sim.config.migration`): the config it
gives is the one of today's layout, every robot's table holding the section's keys."""

from __future__ import annotations

import pytest

from planner.decision.registry import make_planner
from planner.errors import PlannerInputError
from sim.config import from_dict
from sim.config.migration import migrated
from sim.errors import InvalidInput


def test_the_old_section_gives_the_config_of_tables():
    old = {"robots": 2, "robot": {"pick_pause_s": 0.5, "idle_sleep": False}}
    new = {"robots": [{"pick_pause_s": 0.5, "idle_sleep": False}] * 2}
    assert migrated(old, None) == new
    assert from_dict(old) == from_dict(new)
    tables = {"robots": [{"x_m": 0.0}, {"x_m": 2.0, "pick_pause_s": 1.0}]}
    both = from_dict({**tables, "robot": {"pick_pause_s": 0.25}})
    assert [r.pick_pause_s for r in both.robots] == [0.25, 1.0]  # a table's own key wins


def test_a_file_without_the_section_is_left_as_it_is():
    data = {"robots": 3}
    assert migrated(data, None) is data


@pytest.mark.parametrize(
    ("section", "field", "allowed"),
    [
        ({"pick_pause_s": 3.0}, "robot.pick_pause_s", "0..2 s"),
        ({"x_m": 1.0}, "robot.x_m", "one of idle_sleep, pick_pause_s, place_pause_s"),
        (1.0, "robot", "a table [robot]"),
    ],
)
def test_a_bad_section_is_refused_naming_its_key(section, field, allowed):
    with pytest.raises(InvalidInput) as refused:
        migrated({"robot": section}, "old.toml")
    assert (refused.value.field, refused.value.allowed) == (field, allowed)
    assert refused.value.where == "old.toml"


def test_an_old_manifest_with_the_robot_section_repeats_its_run_byte_for_byte(tmp_path):
    """A manifest written before `[[robots]]` (its config with `robots = 2` and `[robot]`) runs
    the episode of today's layout: the same picks.csv bytes, the same episodes.csv (wall-clock
    columns aside)."""
    import json

    from sim.cli.main import main
    from sim.results import outputs

    first, again = tmp_path / "first", tmp_path / "again"
    common = ["--perception", "truth", "--items", "8", "--duration", "6", "--seed", "5"]
    today = tmp_path / "today.toml"
    today.write_text("[[robots]]\npick_pause_s = 0.25\n[[robots]]\npick_pause_s = 0.25\n")
    assert main(["run", "--config", str(today), "--out", str(first), *common, "--quiet"]) == 0
    old = json.loads((first / "manifest.json").read_text())
    config = old["config"]
    config["robot"] = {"pick_pause_s": config["robots"][0]["pick_pause_s"]}
    config["robots"] = len(config["robots"])  # the old layout: a count and one shared section
    (tmp_path / "old.json").write_text(json.dumps(old))
    assert main(["run", "--config", str(tmp_path / "old.json"), "--out", str(again), "-q"]) == 0
    assert (first / "picks.csv").read_bytes() == (again / "picks.csv").read_bytes()
    a, b = (outputs.strip_wall_clock((d / "episodes.csv").read_text()) for d in (first, again))
    assert a == b


def test_a_file_naming_the_planner_oracle_runs_seen_best():
    """`oracle` was `seen_best`'s name: an old file or manifest naming it still loads, as
    `seen_best`; the registry refuses the old name."""
    old = {"planner": "oracle", "perception": "truth"}
    assert from_dict(old) == from_dict({**old, "planner": "seen_best"})
    with pytest.raises(PlannerInputError, match="seen_best"):
        make_planner("oracle")
