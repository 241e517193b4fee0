"""`sortsim run --help` says what the code accepts: the ranges in its help are the config's own
(a belt speed factor between the thesis's three runs, say)."""

from __future__ import annotations

import argparse

import pytest

from sim import config as episode_config
from sim.cli.run import add_arguments
from sim.errors import InvalidInput


def _help() -> str:
    parser = argparse.ArgumentParser(prog="sortsim run")
    add_arguments(parser)
    return " ".join(parser.format_help().split())


def test_the_speed_factor_help_gives_the_range_the_config_takes():
    text = _help()
    assert "1, 1.2 or 1.5 of" not in text
    assert "any factor from 0.73 to 1.5" in text
    assert episode_config.load(None, speed_factor=1.3).speed_factor == 1.3  # between the three
    with pytest.raises(InvalidInput, match=r"0\.730\.\.1\.5"):
        episode_config.load(None, speed_factor=0.7)


@pytest.mark.parametrize(
    ("key", "range_text"),
    [("duration_s", "1..36000"), ("items", "1..20000"), ("seed", "0..2^63-1")],
)
def test_the_ranges_in_the_help_are_the_configs(key, range_text):
    assert range_text in _help()
    with pytest.raises(InvalidInput) as refused:
        episode_config.load(None, **{key: -1})
    assert range_text in refused.value.allowed
