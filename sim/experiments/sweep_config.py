"""A sweep: a grid of episodes (variants x planners x speed factors x item counts x seeds).

TOML layout (`experiments/*.toml`)::

    [sweep]
    name = "table_4_2"
    table = "4.2"                  # thesis table printed beside ours (sim/data/thesis_tables.toml)
    speed_factors = [1.0, 1.2, 1.5]  # or belt_speeds_mps = [0.2, 0.25] (m/s), not both
    items = [50, 100, 120, 150]
    planners = ["qlearning"]
    seeds = 10                     # a count (seed_offset .. seed_offset+n-1) or a list
    seed_offset = 0
    duration_s_by_items = { 80 = 61.0 }   # optional: flow duration per item count [s]

    [base]                         # fixed settings of every episode (episode-config keys)
    perception = "truth"
    duration_s = 90.0

    [[variants]]                   # optional named overrides, e.g. class values of table 4.3
    name = "weight_paper"
    values = { paper = 150.22 }

The keys the variants set (`SweepConfig.variant_keys`, dotted for tables: `values.paper`) become
columns `variant.<key>` of the sweep's episodes.csv and picks.csv, each holding the value the
episode ran with (`variant_values`): the variant's own, else the base's or the default.

Every episode's config is built (and so validated, the flow's density included) when the sweep
loads, so a bad value stops the sweep before its first episode, naming the key, the file and the
grid point. The grid's size (the product of the axes' lengths) is checked before the grid is
built: at most `MAX_EPISODES`. A sweep's `identity` is a hash of every grid point's resolved
config, seeds aside, so the runner can tell this sweep's results from another's (adding seeds
keeps the identity: the sweep resumes and grows). Keys added to the episode config later
(`LATER_KEYS`) enter the identity only when set away from the value that behaves as before
they existed, so a sweep started before them resumes only when it would still run the same.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sim.checks import check, is_integer
from sim.config.episode import SECTIONS, EpisodeConfig
from sim.config.fields import Range, check_keys, setting, validate
from sim.config.loading import from_dict as episode_from_dict
from sim.config.loading import read_toml
from sim.config.plant import CUP_DIAMETER_M, MAX_ROBOTS
from sim.config.robots import SECTION_KEYS, resized_tables
from sim.config.sections import InfeedRate
from sim.config.settings import WORLD_NUMBERS
from sim.errors import InvalidInput
from sim.flow.feed_rate import FEED_KEYS
from sim.flow.limits import BELT_WIDTH_M
from sim.results import outputs

_TOP_KEYS = {"sweep", "base", "variants"}
_GRID_FIELDS = ("speed_factor", "items", "planner", "seed")
VARIANT_PREFIX = "variant."
"""Prefix of the columns holding the settings the sweep's variants change."""
MAX_EPISODES = 100_000
"""Most episodes a sweep may hold (variants x planners x speed factors x item counts x seeds)."""


@dataclass(frozen=True)
class EpisodeSpec:
    """One episode of a sweep: its grid coordinates and its validated config."""

    variant: str
    config: EpisodeConfig

    @property
    def key(self) -> str:
        """Identity of the episode in the sweep's episodes.csv (for resuming)."""
        c = self.config
        return episode_key(self.variant, c.planner, c.speed_factor, c.items, c.seed)


SPEED_FACTOR_DECIMALS = outputs.DECIMALS["speed_factor"]
"""Decimals of a speed factor in an episode's key: as episodes.csv writes it."""


def episode_key(variant: str, planner: str, speed_factor: float, items: int, seed: int) -> str:
    """The string that identifies one episode of a sweep: the speed factor at the decimals
    episodes.csv writes it with, so a row read back names the episode it came from (a belt
    speed in m/s gives factors such as 0.2 / 0.185 = 1.08108...)."""
    factor = f"{float(speed_factor):.{SPEED_FACTOR_DECIMALS}f}"
    return f"{variant}|{planner}|{factor}|{int(items)}|{int(seed)}"


@dataclass(frozen=True)
class SweepConfig:
    """A validated sweep: name, thesis table id and the ordered list of episodes."""

    name: str
    table: str | None
    episodes: tuple[EpisodeSpec, ...]
    path: str | None = None
    identity: str = ""
    """Hash of every grid point's resolved config, seeds aside (see the module docstring)."""
    variant_keys: tuple[str, ...] = ()
    """The config keys any variant sets, dotted for tables (`values.paper`), in the order they
    first appear in the file."""

    @property
    def variant_columns(self) -> tuple[str, ...]:
        """The CSV columns of `variant_keys` (`variant.<key>`), after the usual ones."""
        return tuple(VARIANT_PREFIX + key for key in self.variant_keys)


def _dotted(table: dict[str, Any], prefix: str = "") -> list[str]:
    """The keys of a TOML table, a sub-table's as `table.key`."""
    keys = []
    for key, value in table.items():
        if isinstance(value, dict):
            keys.extend(_dotted(value, f"{prefix}{key}."))
        else:
            keys.append(prefix + key)
    return keys


def variant_values(spec: EpisodeSpec, keys: tuple[str, ...]) -> dict[str, Any]:
    """The values an episode runs with of the keys its sweep's variants set.

    Args:
        spec: The episode.
        keys: The dotted keys (`values.paper`, `robots`, `robot.pick_pause_s`).

    Returns:
        {`variant.<key>`: the variant's value, the base's or the default}, read from the
        settings in the layout of before per-robot pauses (`settings_as_before`: `robots` a
        count where the robots are at the default places); a world number the config leaves to
        its preset (`world`), the preset's; `min_class_confidence` left to the classifier, the
        threshold applied; None (an empty cell) for a key the config does not hold.
    """
    settings = settings_applied(spec.config)
    out = {}
    for key in keys:
        value: Any = settings
        for part in key.split("."):
            value = value.get(part) if isinstance(value, dict) else None
        if value is None and key in WORLD_NUMBERS:
            value = getattr(spec.config.world_variation, key)
        out[VARIANT_PREFIX + key] = value
    return out


def settings_as_before(settings: dict[str, Any]) -> dict[str, Any]:
    """An episode config's `to_dict` in the layout it had before each robot had its own
    pauses, for the sweep's identity and variant columns (which so stay what they were for
    every sweep that could be written then): `robots` the count, or the `[[robots]]` tables
    with only `x_m` and `materials`, and the pauses in one `[robot]` section. Robots whose
    pauses differ (new) keep the one `robots` array.

    Args:
        settings: `EpisodeConfig.to_dict()`.

    Returns:
        The settings in that layout (a new dict; `settings` is not changed).
    """
    tables = settings["robots"]
    shared = [{k: t[k] for k in SECTION_KEYS} for t in tables]
    if any(s != shared[0] for s in shared):
        return settings
    placed = [{k: v for k, v in t.items() if k not in SECTION_KEYS} for t in tables]
    return settings | {"robots": placed if any(placed) else len(tables), "robot": shared[0]}


def settings_applied(config: EpisodeConfig) -> dict[str, Any]:
    """`settings_as_before(config.to_dict())` with the confidence threshold the episode applies
    (a config that leaves it to the classifier holds None): so a grid point at the classifier's
    own threshold is told from one at 0, and a sweep begun when 0 was every classifier's
    default does not resume under the rule. Likewise the cup's diameter applied (unset: one
    robot's 0.06 m, a line's 0.05 m): a line's sweep begun when every cup was 60 mm does not
    resume with the line's cup."""
    settings = settings_as_before(config.to_dict())
    settings["min_class_confidence"] = config.applied_min_class_confidence
    settings["cup"] = {**settings["cup"], "diameter_m": config.cup_diameter_m}
    return settings


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        elif key == "robots" and _count(value) and _tables(out.get(key)):
            out[key] = resized_tables(out[key], value)  # N robots keeping the base's pauses
        else:
            out[key] = value
    return out


def _count(value: object) -> bool:
    """Whether `value` is a robot count that can be run (1..`MAX_ROBOTS`)."""
    return is_integer(value) and 1 <= value <= MAX_ROBOTS


def _tables(value: object) -> bool:
    """Whether `value` is a non-empty array of `[[robots]]` tables (as parsed)."""
    return isinstance(value, list) and bool(value) and all(isinstance(t, dict) for t in value)


@dataclass(frozen=True)
class SweepTable:
    """The `[sweep]` table's keys (the layout: module docstring); the axes are lists, checked
    where the grid is built, every grid point by the episode's schema."""

    name: object = None
    table: object = None
    speed_factors: object = None
    belt_speeds_mps: object = None
    items: object = None
    planners: object = None
    seeds: object = 1
    seed_offset: int = setting(0, range=Range(0, 2**63 - 1, "an integer >= 0", integer=True))
    duration_s_by_items: object = None


@dataclass(frozen=True)
class _Axes:
    """The grid's axes, outermost first, and the flow's durations by item count."""

    variants: list[dict[str, Any]]
    planners: list
    speeds: list[dict]
    item_counts: list
    seeds: list
    by_items: dict

    def size(self) -> tuple[int, str]:
        lengths = [len(a) for a in (self.variants, self.planners, self.speeds)]
        lengths += [len(self.item_counts), len(self.seeds)]
        return math.prod(lengths), " x ".join(str(n) for n in lengths)


def _list(sweep: dict[str, Any], key: str, default: list, where: str) -> list:
    value = sweep.get(key, default)
    if not isinstance(value, list) or not value:
        raise InvalidInput(f"sweep.{key}", "a non-empty list", value, where)
    return value


def _seeds(sweep: dict[str, Any], where: str) -> list[int]:
    seeds = sweep.get("seeds", 1)
    offset = sweep.get("seed_offset", 0)
    validate(SweepTable(seed_offset=offset), "sweep.", where)
    if is_integer(seeds):
        check(1 <= seeds <= 100000, "sweep.seeds", "1..100000 or a list of seeds", seeds, where)
        return list(range(offset, offset + seeds))
    return _list(sweep, "seeds", [], where)


def from_dict(data: dict[str, Any], where: str) -> SweepConfig:
    """A `SweepConfig` from a parsed TOML dict; every episode config validated."""
    sweep, base = _sweep_and_base(data, where)
    axes = _axes(sweep, base, data.get("variants", [{"name": "base"}]), where)
    episodes, points = _grid(base, axes, where)
    keys = [e.key for e in episodes]
    if len(set(keys)) != len(keys):
        raise InvalidInput("sweep", "grid axes without repeated values", None, where)
    variant_keys: list[str] = []
    for variant in axes.variants:
        for key in _dotted({k: v for k, v in variant.items() if k != "name"}):
            if key not in variant_keys:
                variant_keys.append(key)
    name = sweep.get("name", Path(where).stem)
    table = sweep.get("table")
    for key, value in (("name", name), ("table", table)):
        if value is not None and not isinstance(value, str | int | float):
            raise InvalidInput(f"sweep.{key}", "a string", value, where)
    return SweepConfig(
        name=str(name),
        table=None if table is None else str(table),
        episodes=tuple(episodes),
        path=where,
        identity=hashlib.sha256("\n".join(sorted(points)).encode()).hexdigest()[:16],
        variant_keys=tuple(variant_keys),
    )


def _sweep_and_base(data: dict[str, Any], where: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """The `[sweep]` and `[base]` tables, their keys checked (a grid axis is not a base key)."""
    for key in data:
        if key not in _TOP_KEYS:
            raise InvalidInput(key, "one of " + ", ".join(sorted(_TOP_KEYS)), None, where)
    sweep = data.get("sweep", {})
    base = data.get("base", {})
    if not isinstance(sweep, dict) or not isinstance(base, dict):
        raise InvalidInput("sweep/base", "TOML tables [sweep] and [base]", None, where)
    check_keys(SweepTable, sweep, "sweep.", where)
    for key in _GRID_FIELDS:
        if key in base:
            raise InvalidInput(f"base.{key}", "set in [sweep] (it is a grid axis)", None, where)
    return sweep, base


def _axes(sweep: dict[str, Any], base: dict[str, Any], variants: object, where: str) -> _Axes:
    """The grid's axes of the `[sweep]` table, its size at most `MAX_EPISODES`."""
    speeds = _speed_axis(sweep, base, where)
    by_items = sweep.get("duration_s_by_items", {})
    if not isinstance(by_items, dict):
        raise InvalidInput("sweep.duration_s_by_items", "a table items = seconds", by_items, where)
    if not isinstance(variants, list) or not all(isinstance(v, dict) for v in variants):
        raise InvalidInput("variants", "an array of tables [[variants]]", None, where)
    names = [v.get("name", "") for v in variants]
    if not all(isinstance(n, str) and n for n in names) or len(set(names)) != len(names):
        raise InvalidInput("variants.name", "a unique, non-empty name per variant", names, where)
    planners = _list(sweep, "planners", ["qlearning"], where)
    item_counts = _list(sweep, "items", [100], where)
    if "items" not in sweep and _section_key(base, "infeed", *FEED_KEYS):
        item_counts = [None]  # the base's feed rate gives the count
    axes = _Axes(variants, planners, speeds, item_counts, _seeds(sweep, where), by_items)
    size, sizes = axes.size()
    if size > MAX_EPISODES:
        allowed = (
            f"at most {MAX_EPISODES} episodes (variants x planners x speed_factors x items x seeds)"
        )
        raise InvalidInput("sweep", allowed, f"{sizes} = {size}", where)
    unknown = [k for k in by_items if k not in {str(n) for n in item_counts}]
    if unknown:
        allowed = "item counts of sweep.items"
        raise InvalidInput("sweep.duration_s_by_items", allowed, unknown, where)
    return axes


def _grid(base: dict[str, Any], axes: _Axes, where: str) -> tuple[list[EpisodeSpec], list[str]]:
    """Every episode of the grid, its config validated by the episode's schema, and each grid
    point's resolved config (seeds aside) for the identity."""
    episodes, points = [], []
    for variant in axes.variants:
        over = {k: v for k, v in variant.items() if k != "name"}
        for planner in axes.planners:
            for speed in axes.speeds:
                for items in axes.item_counts:
                    point = {"planner": planner, **speed}
                    if items is not None:
                        point["items"] = items
                    if str(items) in axes.by_items:
                        point["duration_s"] = axes.by_items[str(items)]
                    merged = _merge(_merge(base, over), point)
                    first = None
                    for seed in axes.seeds:
                        config = _grid_point(merged, seed, variant["name"], where, first)
                        episodes.append(EpisodeSpec(variant=variant["name"], config=config))
                        first = first or config
                    assert first is not None  # seeds are never empty
                    points.append(_resolved(variant["name"], first))
    return episodes, points


def _speed_axis(sweep: dict[str, Any], base: dict[str, Any], where: str) -> list[dict]:
    """The belt-speed axis's grid points: `speed_factors` (default [1.0]) or `belt_speeds_mps`
    (then each point's `[belt] speed_mps`), not both, nor the latter beside `[base]`'s.

    Returns:
        One partial config per speed ({"speed_factor": f} or {"belt": {"speed_mps": v}}).
    """
    if "belt_speeds_mps" not in sweep:
        if "speed_factors" not in sweep and _section_key(base, "belt", "speed_mps"):
            return [{}]  # the base's belt speed
        return [{"speed_factor": f} for f in _list(sweep, "speed_factors", [1.0], where)]
    allowed = "unset when sweep.belt_speeds_mps is given (one belt-speed axis)"
    check("speed_factors" not in sweep, "sweep.speed_factors", allowed, None, where)
    given = _section_key(base, "belt", "speed_mps")
    check(not given, "base.belt.speed_mps", "set in [sweep] (it is a grid axis)", None, where)
    return [{"belt": {"speed_mps": v}} for v in _list(sweep, "belt_speeds_mps", [], where)]


def _section_key(table: dict[str, Any], section: str, *keys: str) -> bool:
    """Whether `table`'s `[section]` sets any of `keys`."""
    inner = table.get(section)
    return isinstance(inner, dict) and any(k in inner for k in keys)


def _grid_point(
    merged: dict[str, Any], seed: object, variant: str, where: str, like: EpisodeConfig | None
) -> EpisodeConfig:
    """The config of one grid point (`like`'s with another seed, when given: faster); a
    refusal names the point's grid coordinates."""
    try:
        if like is not None:
            return like.replace(seed=seed)
        return episode_from_dict({**merged, "seed": seed}, where)
    except InvalidInput as exc:
        belt = merged.get("belt")
        speed_mps = belt.get("speed_mps") if isinstance(belt, dict) else None
        coords = ", ".join(
            f"{k} {v!r}"
            for k, v in (
                ("variant", variant),
                ("planner", merged.get("planner")),
                ("speed_factor", merged.get("speed_factor")),
                ("belt.speed_mps", speed_mps),
                ("items", merged.get("items")),
                ("seed", seed),
            )
            if v is not None or k in ("speed_factor", "items")
        )
        at = f"{where} at ({coords})"
        if exc.where and exc.where != where:  # another file's key (the catalogue's): name both
            at = f"{exc.where}, for {at}"
        raise InvalidInput(exc.field, exc.allowed, exc.got, at) from None


LATER_TABLE_KEYS = {"belt": {"speed_mps": None, "width_m": BELT_WIDTH_M}}
"""Keys added to a table after sweeps were first identified, with the value of before: left
out of their table at it (so of the identity too, below)."""
LATER_KEYS: dict[str, Any] = {
    "min_class_confidence": 0.0,
    "world": "uniform",
    **{name: None for name in WORLD_NUMBERS},
    "classifier": "hmm",
    "depth_noise": False,
    "catalogue": "",
    "flow": {},
    "robots": 1,
    "coordination": "coordinated",
    **{
        name: dataclasses.asdict(SECTIONS[name]())
        for name in ("camera", "cup", "belt", "hmm", "economics")
    },
}
LATER_KEYS["belt"] = {**LATER_KEYS["belt"], "infeed_hold": False}  # no hold before it existed
LATER_KEYS |= {"horizon_s": None, "infeed": dataclasses.asdict(InfeedRate())}
LATER_KEYS |= {
    "timeline": dataclasses.asdict(SECTIONS["timeline"]()),
    "faults": [],
    "faults_random": {},
}
for _table, _keys in LATER_TABLE_KEYS.items():
    LATER_KEYS[_table] = {k: v for k, v in LATER_KEYS[_table].items() if k not in _keys}
LATER_KEYS["cup"] = {**LATER_KEYS["cup"], "diameter_m": CUP_DIAMETER_M}  # a line's cup was 60 mm
"""Episode-config keys added after sweeps were first identified, with the value that gives the
behaviour from before they existed (not their default): a grid point at that value is left out
of the identity, so an old sweep resumes only when its episodes would still run as they did
(the world was uniform, the camera's depth exact and its items classed by the HMMs)."""


def _resolved(variant: str, config: EpisodeConfig) -> str:
    """One grid point's resolved config, seed aside, as canonical JSON (for the identity); a
    later key at its default is left out (`LATER_KEYS`)."""
    settings = settings_applied(config)
    settings.pop("seed")
    for table, keys in LATER_TABLE_KEYS.items():
        inner = settings.get(table)
        for key, before in keys.items():
            if isinstance(inner, dict) and inner.get(key, before) == before:
                inner.pop(key, None)
    for key, default in LATER_KEYS.items():
        if settings.get(key) == default:
            settings.pop(key)
    return json.dumps({"variant": variant, **settings}, sort_keys=True)


def load(path: Path) -> SweepConfig:
    """The sweep of TOML `path`, refused in one line if anything in it is wrong."""
    return from_dict(read_toml(Path(path)), str(path))


def first_seeds(sweep: SweepConfig, n: int) -> SweepConfig:
    """The same sweep with only the `n` smallest seeds of each grid point."""
    seeds = sorted({e.config.seed for e in sweep.episodes})[:n]
    kept = tuple(e for e in sweep.episodes if e.config.seed in seeds)
    return dataclasses.replace(sweep, episodes=kept)
