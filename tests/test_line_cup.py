"""A line's cup: 50 mm by default for two robots or more, the single cell's 60 mm for one; a cup
given is the cup run. Unset stays unset through a manifest; a sweep's identity holds the cup
applied, so a line's sweep begun with 60 mm cups does not resume with 50 mm ones."""

from __future__ import annotations

import pytest

from sim import config as episode_config
from sim.config.plant import CUP_DIAMETER_M, LINE_CUP_DIAMETER_M
from sim.experiments import sweep_config


@pytest.mark.parametrize(("robots", "diameter"), [(1, 0.06), (2, 0.05), (3, 0.05), (4, 0.05)])
def test_the_cup_by_default_is_the_lines_for_two_robots_or_more(robots, diameter):
    assert (CUP_DIAMETER_M, LINE_CUP_DIAMETER_M) == (0.06, 0.05)
    for c in (
        episode_config.load(None, robots=robots),  # --robots N: a count replaced
        episode_config.from_dict({"robots": robots}),  # a file's or a sweep's
        episode_config.EpisodeConfig().replace(robots=robots),
    ):
        assert c.cup.diameter_m is None
        assert c.cup_diameter_m == diameter
        assert c.cell_settings.cup_diameter_m == diameter


def test_a_cup_given_is_the_cup_run_whatever_the_robots():
    sixty = episode_config.from_dict({"robots": 2, "cup": {"diameter_m": 0.06}})
    assert sixty.cup_diameter_m == 0.06 and sixty.cell_settings.cup_diameter_m == 0.06
    assert sixty.replace(robots=4).cup_diameter_m == 0.06
    one = episode_config.from_dict({"cup": {"diameter_m": 0.05, "vacuum_pa": 6e4}})
    assert one.cup_diameter_m == 0.05 and one.cup.vacuum_pa == 6e4
    vacuum_only = episode_config.from_dict({"robots": 3, "cup": {"vacuum_pa": 6e4}})
    assert vacuum_only.cup_diameter_m == 0.05


def test_unset_stays_unset_through_a_manifest():
    line = episode_config.load(None, robots=2)
    assert line.to_dict()["cup"] == {"diameter_m": None, "vacuum_pa": 80000.0}
    again = episode_config.from_dict(line.to_dict())
    assert again == line and again.cup_diameter_m == 0.05


def _sweep(tmp_path, robots: tuple[int, ...], cup: str = "") -> sweep_config.SweepConfig:
    path = tmp_path / "s.toml"
    variants = "".join(f"[[variants]]\nname = '{n}'\nrobots = {n}\n" for n in robots)
    path.write_text(
        "[sweep]\nitems = [30]\nseeds = 1\n[base]\nduration_s = 20.0\nperception = 'truth'\n"
        + cup
        + variants
    )
    return sweep_config.load(path)


SIXTY, FIFTY = "cup = { diameter_m = 0.06 }\n", "cup = { diameter_m = 0.05 }\n"


def test_a_sweeps_identity_and_variant_columns_hold_the_cup_applied(tmp_path):
    line = _sweep(tmp_path, (2,)).identity
    assert line == _sweep(tmp_path, (2,), FIFTY).identity
    assert line != _sweep(tmp_path, (2,), SIXTY).identity  # begun with 60 mm: not resumed
    one = _sweep(tmp_path, (1,)).identity
    assert one == _sweep(tmp_path, (1,), SIXTY).identity  # a single cell's sweep resumes
    two, single = _sweep(tmp_path, (2, 1)).episodes
    key = ("cup.diameter_m",)
    assert sweep_config.variant_values(two, key) == {"variant.cup.diameter_m": 0.05}
    assert sweep_config.variant_values(single, key) == {"variant.cup.diameter_m": 0.06}
