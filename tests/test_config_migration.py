"""An old file's `[robot]` section is read at the edge (`sim.config.migration`): the config it
gives is the one of today's layout, every robot's table holding the section's keys."""

from __future__ import annotations

import pytest

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
