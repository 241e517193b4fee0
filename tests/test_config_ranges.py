"""Every documented range holds end to end.

The cases are generated from the validation tables themselves, never written out by hand:
`sim.config.RANGES` (every numeric key of a config file) and the item catalogue's
limits (`HALF_SIZE_RANGE_M`, `MASS_RANGE_KG`, `FRICTION_RANGES`). Each key is set, in a config
file, at both ends of its range and just outside them: inside loads (and a short episode runs
for a few representative keys), outside is refused when the file loads, in one line naming the
key and the file.
"""

from __future__ import annotations

import math
import re

import pytest

from sim import config as episode_config
from sim.config import RANGES, Range
from sim.episode.runner import run_episode
from sim.errors import InvalidInput
from sim.flow import catalogue as catalogue_module
from sim.paths import DATA_DIR

MATERIALS = 3  # the built-in catalogue's: paper, plastic, aluminium
STRIPES = 5
TABLES = {
    "flow.mix": ("paper", "plastic", "aluminium"),
    "flow.mix_types": ("paper_sheet_a4", "pet_bottle_0l5", "can_330_lying"),
}
"""The names a table of shares is given for (its first takes the end, the rest share what is
left of 1)."""
TOP_SPEED_MPS = 1.5 * 0.185


def _epsilon(end: float) -> float:
    return 1e-6 * max(1.0, abs(end))


def inside(r: Range) -> list[float]:
    """Both ends, as far in as the range goes."""
    hi = math.nextafter(r.hi, r.lo) if r.hi_open else r.hi
    return [r.lo, hi]


def outside(r: Range) -> list[float]:
    """Just outside both ends (past any slack the check allows)."""
    if r.integer:
        return [r.lo - r.multiple, r.hi + r.multiple]
    hi = r.hi if r.hi_open else r.hi + r.slack[1] + _epsilon(r.hi)
    return [r.lo - r.slack[0] - _epsilon(r.lo), hi]


def _key(name: str) -> str:
    return name.replace("<material>", "paper")


def _value(r: Range, end: float, key: str) -> object:
    """The TOML value of `key` with `end` in it (a list's first entry; the rest share what is
    left of 1)."""
    if not r.entries:
        return end
    if r.entries == "table":
        first, *rest = TABLES[key]
        return {first: end, **{name: (1.0 - end) / len(rest) for name in rest}}
    n = STRIPES if key.endswith("stripe_priors") else MATERIALS
    row = [end] + [(1.0 - end) / (n - 1)] * (n - 1)
    return row if r.entries == "list" else [row] * n


def _companions(key: str, value, tmp_path) -> dict[str, object]:
    """Other keys an end needs to be inside the other rules (the belt's density, the camera's
    aspect, crumpled + folded <= 1); each names the rule it satisfies."""
    if key in ("infeed.items_per_m", "infeed.kg_per_h") and value < 1:
        return {"duration_s": 36000.0}  # a thin feed gives at least one item over a long flow
    if key == "infeed.items_per_s":
        return {"belt.speed_mps": TOP_SPEED_MPS}  # the fastest feed fills the fastest belt
    if key == "infeed.kg_per_h":
        # The heaviest feed: items of the heaviest mass (the world uniform: none heavier) on
        # the fastest belt.
        path = _catalogue(tmp_path, "mass", catalogue_module.MASS_RANGE_KG[1], every=True)
        return {"catalogue": f'"{path}"', "world": '"uniform"', "belt.speed_mps": TOP_SPEED_MPS}
    if key == "items":
        return {"duration_s": 36000.0}  # 20000 items need a long flow (items per metre)
    if key == "duration_s":
        return {"items": 1}  # a 1 s flow carries few items
    if key == "camera.width":
        return {"camera.height": value * 9 // 16}  # the calibration's 16:9
    if key in ("crumpled_share", "folded_share"):
        other = "folded_share" if key == "crumpled_share" else "crumpled_share"
        return {other: 0.0}  # crumpled_share + folded_share <= 1
    return {}


def _toml(value) -> str:
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    return str(value)


def _text(settings: dict[str, object]) -> str:
    lines = []
    for key, value in settings.items():
        match = re.fullmatch(r"robots\[0\]\.(\w+)", key)
        if match:
            lines.append(f"robots = [{{{match[1]} = {_toml(value)}}}]")
        else:
            lines.append(f"{key} = {_toml(value)}")
    return "\n".join(lines) + "\n"


CASES = [
    pytest.param(name, end, is_inside, id=f"{_key(name)}-{'in' if is_inside else 'out'}-{end!r}")
    for name, r in RANGES.items()
    for is_inside, ends in ((True, inside(r)), (False, outside(r)))
    for end in ends
]


def test_every_numeric_key_is_in_the_table():
    """Every number a config holds has its range in the table (the sections' and the world's
    fields, the top-level numbers)."""
    config = episode_config.EpisodeConfig()
    numbers = set()
    for key, value in config.to_dict().items():
        if isinstance(value, dict) and key not in ("values", "flow"):
            numbers |= {f"{key}.{k}" for k, v in value.items() if type(v) in (int, float)}
        elif type(value) in (int, float):
            numbers.add(key)
    numbers |= set(episode_config.WORLD_NUMBERS)
    tied = {"camera.height"}  # width x 9/16: no range of its own
    assert numbers - tied <= set(RANGES), numbers - tied - set(RANGES)
    assert len(CASES) == 4 * len(RANGES)


@pytest.mark.parametrize(("name", "end", "is_inside"), CASES)
def test_both_ends_load_and_just_outside_is_refused_naming_key_and_file(
    tmp_path, name, end, is_inside
):
    key = _key(name)
    r = RANGES[name]
    value = _value(r, end, key)
    path = tmp_path / "config.toml"
    path.write_text(_text({key: value, **_companions(key, value, tmp_path)}))
    if is_inside:
        config = episode_config.load(path)
        if not r.entries and not key.startswith(("robot", "values")):
            section, _, field = key.rpartition(".")
            got = getattr(getattr(config, section), field) if section else getattr(config, key)
            assert got == value
        return
    with pytest.raises(InvalidInput) as refused:
        episode_config.load(path)
    assert refused.value.field == key, str(refused.value)
    assert refused.value.where == str(path), str(refused.value)


RUN = [
    ("speed_factor", 0),
    ("speed_factor", 1),
    ("robot.pick_pause_s", 1),
    ("robot.place_pause_s", 1),
    ("cup.diameter_m", 0),
    ("cup.diameter_m", 1),
    ("size_jitter", 1),
    ("observation_period_s", 0),
    ("observation_period_s", 1),
    ("belt.width_m", 0),
    ("belt.width_m", 1),
]
"""Representative keys whose ends run a short episode (index 0: the low end, 1: the high)."""


@pytest.mark.parametrize(
    ("name", "end"), RUN, ids=[f"{n}-{'lo' if e == 0 else 'hi'}" for n, e in RUN]
)
def test_representative_ends_run_an_episode(tmp_path, name, end):
    r = RANGES[name]
    value = inside(r)[end]
    path = tmp_path / "config.toml"
    path.write_text(_text({name: value}))
    config = episode_config.load(path, items=4, duration_s=3.0, perception="truth")
    result = run_episode(config)
    row = result.episode_row
    assert row["entered"] == 4
    assert row["picked"] + row["missed"] + row["dropped"] == 4


# ----------------------------------------------------------------------------- the catalogue

ITEM_KEYS = {
    "mass": [(catalogue_module.MASS_RANGE_KG, None)],
    "size": [(catalogue_module.HALF_SIZE_RANGE_M, None)],
    "friction": [(r, k) for k, r in enumerate(catalogue_module.FRICTION_RANGES)],
}
FIRST = {"size": [0.1485, 0.105, 0.001], "friction": [0.55, 0.005, 0.0001], "mass": 0.010}
"""The first item's (`paper_sheet_a4`) values in the built-in catalogue."""


def _catalogue(tmp_path, key: str, value, every: bool = False):
    """The built-in catalogue with the first item's (or every item's) `key` set to `value`."""
    text = (DATA_DIR / "items.toml").read_text()
    pattern = {"mass": r"^mass = .*$", "size": r"^size = .*$", "friction": r"^friction = .*$"}
    line = f"{key} = {_toml(value)}"
    if every and key == "friction":
        k = value  # (index, end): every item's one component
        index, end = k

        def one(match):
            parts = match[1].split(", ")
            parts[index] = repr(end)
            return "friction = [" + ", ".join(parts) + "]"

        text = re.sub(r"^friction = \[(.*)\]$", one, text, flags=re.M)
    elif every:
        text = re.sub(pattern[key], line, text, flags=re.M)
    else:
        text = re.sub(pattern[key], line, text, count=1, flags=re.M)
    path = tmp_path / f"catalogue_{key}.toml"
    path.write_text(text)
    return path


def _item_value(key: str, component: int | None, end: float):
    value = FIRST[key]
    if key == "size":
        return [end, 0.105, 0.001] if end > 0.2 else [end, end, end]  # fits the stripes
    if key == "friction":
        out = list(value)
        out[component] = end
        return out
    return end


ITEM_CASES = [
    pytest.param(key, component, end, is_inside, id=f"{key}{component or ''}-{end!r}")
    for key, ranges in ITEM_KEYS.items()
    for (lo, hi), component in ranges
    for is_inside, ends in ((True, (lo, hi)), (False, (lo - _epsilon(lo), hi + _epsilon(hi))))
    for end in ends
]


@pytest.mark.parametrize(("key", "component", "end", "is_inside"), ITEM_CASES)
def test_catalogue_limits_hold_end_to_end(tmp_path, key, component, end, is_inside):
    value = _item_value(key, component, end)
    path = _catalogue(tmp_path, key, value)
    config_path = tmp_path / "config.toml"
    config_path.write_text(f'catalogue = "{path}"\nworld = "uniform"\n')  # nominal sizes
    if is_inside:
        assert episode_config.load(config_path).item_catalogue.types[0].name == "paper_sheet_a4"
        return
    with pytest.raises(InvalidInput) as refused:
        episode_config.load(config_path)
    assert refused.value.field == f"catalogue: {key}", str(refused.value)
    assert str(path) in refused.value.where and "paper_sheet_a4" in refused.value.where


PHYSICS = [
    ("friction", (0, catalogue_module.FRICTION_RANGES[0][0]), 4),
    ("friction", (0, catalogue_module.FRICTION_RANGES[0][1]), 4),
    ("friction", (1, catalogue_module.FRICTION_RANGES[1][1]), 4),
    ("friction", (2, catalogue_module.FRICTION_RANGES[2][1]), 4),
    ("mass", catalogue_module.MASS_RANGE_KG[0], 4),
    ("mass", catalogue_module.MASS_RANGE_KG[1], 0),
]
"""Every item of the catalogue at one end of a limit, and how many of the 6 the robot must
pick at least: the belt carries them all, none is thrown off the belt, MuJoCo warns of nothing.
At 3 kg (the robot's rated payload) the default cup's 226 N (60 mm at 80 kPa) seals but loses
the item to the pick's accelerations: every attempt fails and the items ride on, missed."""


@pytest.mark.parametrize(
    ("key", "value", "least"), PHYSICS, ids=[f"{k}-{v}" for k, v, _ in PHYSICS]
)
def test_a_catalogue_at_its_limits_carries_and_picks(tmp_path, key, value, least):
    path = _catalogue(tmp_path, key, value, every=True)
    config = episode_config.load(
        None, catalogue=str(path), world="uniform", items=6, duration_s=4.0, perception="truth"
    )
    row = run_episode(config).episode_row
    assert row["entered"] == 6 and row["thrown_off"] == 0 and row["mujoco_warnings"] == 0
    assert row["picked"] + row["missed"] + row["dropped"] == 6 and row["dropped"] == 0
    assert row["picked"] >= least


def test_physics_breaking_catalogues_are_refused_before_the_episode(tmp_path):
    """The issue's cases: a vanishing item (MuJoCo refused its mass and inertia with a
    traceback), frictions of 0 and 1e9 (every item thrown off the belt, exit code 0)."""
    for key, value, every in (
        ("size", [1e-5, 1e-5, 1e-5], False),
        ("mass", 1e-9, False),
        ("friction", (0, 0.0), True),
        ("friction", (0, 1e9), True),
    ):
        path = _catalogue(tmp_path, key, value, every)
        with pytest.raises(InvalidInput) as refused:
            episode_config.load(None, catalogue=str(path))
        assert refused.value.field == f"catalogue: {key}"
        assert str(path) in refused.value.where


def test_a_catalogue_inside_its_limits_is_checked_once_varied_naming_key_and_file(tmp_path):
    """Sizes and masses inside the catalogue's limits that the world's size jitter takes out
    of them are refused when the config loads, naming the key, the item and the file with the
    catalogue's own value (not a jittered one in the middle of the episode)."""
    lo, hi = catalogue_module.HALF_SIZE_RANGE_M
    jitter = 0.3
    largest = hi / (1 + jitter)
    for size, ok in (([largest, 0.105, 0.001], True), ([hi * 0.9, 0.105, 0.001], False)):
        path = _catalogue(tmp_path, "size", size)
        config_path = tmp_path / "config.toml"
        config_path.write_text(f'catalogue = "{path}"\nsize_jitter = {jitter}\n')
        if ok:
            episode_config.load(config_path)
            continue
        with pytest.raises(InvalidInput) as refused:
            episode_config.load(config_path)
        assert refused.value.field == "catalogue: size"
        assert str(path) in refused.value.where and "paper_sheet_a4" in refused.value.where
        assert "size_jitter 0.3" in refused.value.allowed and refused.value.got == tuple(size)
    path = _catalogue(tmp_path, "mass", 2.9)
    with pytest.raises(InvalidInput) as refused:
        episode_config.load(None, catalogue=str(path), size_jitter=jitter)
    assert refused.value.field == "catalogue: mass" and refused.value.got == 2.9
    config = episode_config.load(None, catalogue=str(path), world="uniform")  # no variation
    assert config.item_catalogue.types[0].mass == 2.9


def test_a_catalogue_given_as_an_option_reads_before_the_values_are_resolved():
    """`--catalogue` of four materials with the built-in config: the values come from that
    catalogue (they were resolved against the built-in one first and refused)."""
    from sim.paths import EXPERIMENTS_DIR

    path = EXPERIMENTS_DIR / "catalogues" / "pet_hdpe.toml"
    config = episode_config.load(None, catalogue=str(path))
    assert config.materials.names == ("paper", "pet", "hdpe", "aluminium")
    file_config = episode_config.load(EXPERIMENTS_DIR / "four_materials.toml")
    again = episode_config.load(
        EXPERIMENTS_DIR / "four_materials.toml", catalogue=file_config.catalogue
    )
    assert again == file_config


def test_a_sweep_refuses_a_bad_grid_point_before_its_first_episode(tmp_path, capfd):
    """A variant whose catalogue leaves its limits once the variant's jitter varies it: the
    sweep is refused when it loads, naming the key and the catalogue's file, before any
    episode (no folder made)."""
    from sim.cli.main import main

    big = _catalogue(tmp_path, "size", [0.45, 0.105, 0.001])
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(
        f"""
[sweep]
name = "ranges"
items = [4]
planners = ["fifo"]
seeds = 1

[base]
perception = "truth"
duration_s = 3.0

[[variants]]
name = "fine"

[[variants]]
name = "large"
catalogue = "{big}"
size_jitter = 0.3
"""
    )
    code = main(["sweep", "--config", str(sweep), "--out", str(tmp_path / "out")])
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith("sortsim sweep: catalogue: size") and str(big) in err[0]
    assert not (tmp_path / "out").exists()
