"""The episode config reads its files at the edge: the item catalogue is read by the loaders
(`load`, `from_dict`, `EpisodeConfig.build`, `replace`), never by the dataclass's validation;
configs compare by what they run with and pickle whole. The single-value checks are shared
(`sim.checks`), and a sweep's identity is what it was before each robot had its own pauses."""

from __future__ import annotations

import dataclasses
import math
import pickle
import shutil

import pytest

from sim import checks, config
from sim.config.robots import RobotSpec
from sim.errors import InvalidInput
from sim.experiments import sweep_config
from sim.paths import EXPERIMENTS_DIR, REPO_ROOT

FOUR = REPO_ROOT / "experiments" / "catalogues" / "pet_hdpe.toml"


def _no_file_reads(monkeypatch) -> None:
    """Make reading a catalogue fail, so a test shows nothing reads one."""

    def refuse(path):
        raise AssertionError(f"read the catalogue {path!r}")

    monkeypatch.setattr(config, "episode_catalogue", refuse)


def test_the_default_config_and_its_copies_read_no_file(monkeypatch):
    base = config.EpisodeConfig()  # the built-in catalogue, read once per process
    _no_file_reads(monkeypatch)
    assert config.EpisodeConfig(items=30, robots=2).robot_count == 2
    assert base.replace(seed=4).item_catalogue is base.item_catalogue
    assert dataclasses.replace(base, items=20).materials.names == ("paper", "plastic", "aluminium")


def test_a_catalogue_is_read_by_the_loaders_not_by_the_constructor(monkeypatch):
    path = str(FOUR)
    four = config.from_dict({"catalogue": path})
    for c in (
        four,
        config.EpisodeConfig.build(catalogue=path, items=30),
        config.EpisodeConfig().replace(catalogue=path, values=config.Values()),
    ):
        assert c.catalogue == path and c.materials.names == ("paper", "pet", "hdpe", "aluminium")
    with pytest.raises(InvalidInput) as err:
        config.EpisodeConfig(catalogue=path)  # the constructor reads no file
    assert err.value.field == "catalogue" and "from_dict" in str(err.value)
    _no_file_reads(monkeypatch)
    with pytest.raises(InvalidInput) as err:  # a catalogue read for another key
        dataclasses.replace(four, catalogue="")
    assert err.value.field == "catalogue"
    assert four.replace(seed=3).materials.count == 4  # the same catalogue, no file read


def test_a_missing_catalogue_is_refused_naming_the_key_and_the_config_file(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text('catalogue = "no/such/items.toml"\n')
    with pytest.raises(InvalidInput) as err:
        config.load(path)
    assert err.value.field == "catalogue" and err.value.where == str(path)
    assert "\n" not in str(err.value)


def test_configs_compare_by_what_they_run_with_and_pickle_whole(tmp_path):
    copy = tmp_path / "items.toml"
    shutil.copyfile(FOUR, copy)
    first = config.from_dict({"catalogue": str(copy)})
    assert first == config.from_dict({"catalogue": str(copy)}, where="elsewhere.toml")
    assert first != config.load(None)  # another key: another catalogue
    sent = pickle.dumps(first)
    copy.write_text(copy.read_text().replace("value_eur = 0.3", "value_eur = 0.31", 1))
    changed = config.from_dict({"catalogue": str(copy)})
    assert changed.catalogue == first.catalogue and changed != first  # the content differs
    copy.unlink()  # a worker process reads no file
    again = pickle.loads(sent)
    assert again == first and hash(again) == hash(first)
    assert again.item_catalogue.digest == first.item_catalogue.digest


def test_the_checks_are_shared_and_refuse_in_one_line():
    assert checks.is_number(1) and checks.is_number(math.nan) and not checks.is_number(True)
    assert not checks.is_finite_number(math.inf) and checks.is_finite_number(2.5)
    assert checks.is_integer(3) and not checks.is_integer(3.0) and not checks.is_integer(False)
    assert checks.is_finite_in(2, 0, 2) and not checks.is_finite_in(math.nan, 0, 2)
    checks.check(True, "key", "anything", None)
    with pytest.raises(InvalidInput) as err:
        checks.check(False, "robots[1].pick_pause_s", "0..2 s", 3, "c.toml")
    assert str(err.value) == "robots[1].pick_pause_s in c.toml: allowed 0..2 s (got 3)"


@pytest.mark.parametrize(
    ("name", "identity"),
    [
        ("table_4_6_paused", "a51c1ce8bb7978c0"),  # [base.robot] pauses
        ("line", "7d9327ff9be2cf13"),  # robots = N variants
        ("table_4_2", "6f350b21f6a6fb6c"),
    ],
)
def test_a_sweeps_identity_is_the_one_it_had(name, identity):
    """The identity (and the variant columns) read the settings in the layout of before each
    robot had its own pauses, so a sweep started then resumes."""
    sweep = sweep_config.load(EXPERIMENTS_DIR / f"{name}.toml")
    assert sweep.identity == identity


def test_a_sweep_count_over_base_tables_keeps_their_pauses(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(
        "[sweep]\nitems = [30]\n[base]\nduration_s = 20.0\n"
        "[[base.robots]]\npick_pause_s = 0.5\n[[base.robots]]\npick_pause_s = 0.25\n"
        '[[variants]]\nname = "three"\nrobots = 3\n'
        '[[variants]]\nname = "one"\nrobots = 1\n'
    )
    three, one = sweep_config.load(path).episodes
    slow, slower = RobotSpec(pick_pause_s=0.5), RobotSpec(pick_pause_s=0.25)
    assert three.config.robots == (slow, slower, slower) and one.config.robots == (slow,)
    assert sweep_config.variant_values(one, ("robots",)) == {"variant.robots": 1}
    tables = sweep_config.variant_values(three, ("robots",))["variant.robots"]
    assert [t["pick_pause_s"] for t in tables] == [0.5, 0.25, 0.25]  # pauses differ: tables
