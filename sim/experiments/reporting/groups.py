"""How `sortsim report` groups episodes: by every setting in which they differ.

A report averages episodes over their seeds only. Each episode's settings come from its
episodes.csv row and, for what the CSV does not hold, from its folder's `manifest.json` (a
run's `config`; a sweep's `grid`: the grid point's config, matched by variant, planner, belt
speed factor and items). The settings a report groups by and names (`SETTINGS`): the code
(`code_digest`, where the CSV has it), the item catalogue, the variant, the perception, the
robots, a line's coordination, the cup, the belt's width, the energy price, the robots'
economics, the belt speed, the items and the feed (items per metre), and the planner. Episodes
that differ in any of them are never averaged together; the settings that differ over a
report's episodes are its grouping columns (`grouping`), named above its tables.

Every other setting (the rest of the config, flattened to dotted keys: `camera.width`,
`robots[0].pick_pause_s`, `values.paper`; the CSV's `min_class_confidence` and a sweep's
`variant.<key>` columns) must be the same within a group: a group whose episodes differ in
one is refused in one line naming it (`check_groups`), since the report could not say what
its mean is of. A key that one episode's manifest does not record (a folder written before the
key existed), or an episode whose folder has no manifest, is not compared; output-only
settings (`video.*`) never are.
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from planner.motion.belt_speeds import SPEED_X1_MPS
from sim.config.plant import default_cup_diameter_m
from sim.errors import InvalidInput
from sim.experiments.reporting.stats import number
from sim.flow.config import BELT_WIDTH_M
from sim.results.economics import ECONOMICS_COLUMNS

ROW_CONFIG = "@config"
"""The key under which a report's row carries its episode's recorded config (`RowConfig`)."""
NAMED_KEYS = frozenset(
    {
        "seed",
        "planner",
        "perception",
        "speed_factor",
        "items",
        "duration_s",
        "coordination",
        "catalogue",
        "energy_price_eur_per_kwh",
        "min_class_confidence",
        "belt.speed_mps",  # the belt speed's other spelling
        "belt.width_m",
        "infeed.items_per_m",  # the feed's: items over duration_s
        "infeed.items_per_s",
        "infeed.kg_per_h",
    }
)
"""Config keys the grouping settings stand for (or the CSV records: the applied confidence;
the belt speed in m/s and a feed rate are the belt and items columns in a plant's units)."""
NAMED_PREFIXES = ("cup.", "economics.", "video.")
"""Config tables the grouping settings stand for (`video`: output only)."""


@dataclass(frozen=True)
class RowConfig:
    """The config an episode ran with, as its folder's manifest records it.

    Attributes:
        folder: The run or sweep folder.
        config: The config in the TOML layout (`EpisodeConfig.to_dict`), None when the folder
            does not record it.
        others: The settings no grouping setting stands for, flattened ({dotted key: JSON}).
    """

    folder: str
    config: dict | None
    others: dict[str, str]


def flatten(value: Any, key: str = "") -> dict[str, str]:
    """{dotted key: JSON text} of a nested config (arrays of tables as `key[i].sub`; numbers as
    floats, so 90 and 90.0 are one value)."""
    if isinstance(value, dict):
        out: dict[str, str] = {}
        for k, v in value.items():
            out.update(flatten(v, f"{key}.{k}" if key else str(k)))
        return out
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        out = {}
        for i, v in enumerate(value):
            out.update(flatten(v, f"{key}[{i}]"))
        return out
    if isinstance(value, int | float) and not isinstance(value, bool):
        value = float(value)
    return {key: json.dumps(value, sort_keys=True)}


def unnamed(config: dict) -> dict[str, str]:
    """The flattened settings of `config` that no grouping setting stands for."""
    flat = flatten(config)
    return {
        k: v for k, v in flat.items() if k not in NAMED_KEYS and not k.startswith(NAMED_PREFIXES)
    }


def _manifest(folder: Path) -> dict | None:
    try:
        data = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _grid_key(variant: str | None, planner: str, speed: float, items: int) -> tuple:
    return (variant or "base", planner, round(float(speed), 3), int(items))


def config_finder(folder: Path) -> Callable[[dict], dict | None]:
    """A function giving each episodes.csv row of `folder` its recorded config (or None)."""
    manifest = _manifest(folder) or {}
    config = manifest.get("config")
    if manifest.get("kind") == "run" and isinstance(config, dict):
        return lambda row: config
    grid = (
        config.get("grid") if manifest.get("kind") == "sweep" and isinstance(config, dict) else None
    )
    if not isinstance(grid, list):
        return lambda row: None
    points = {}
    for entry in grid:
        c: Any = entry.get("config") if isinstance(entry, dict) else None
        try:
            key = _grid_key(entry.get("variant"), c["planner"], c["speed_factor"], c["items"])
        except (AttributeError, KeyError, TypeError, ValueError):
            continue
        points[key] = c

    def find(row: dict) -> dict | None:
        try:
            key = _grid_key(row.get("variant"), row["planner"], row["speed_factor"], row["n_items"])
        except (KeyError, TypeError, ValueError):
            return None
        return points.get(key)

    return find


def attach_configs(rows: list[dict], folder: Path) -> None:
    """Give each of `folder`'s rows its `RowConfig` (under `ROW_CONFIG`)."""
    find = config_finder(folder)
    made: dict[int, RowConfig] = {}
    for row in rows:
        config = find(row)
        if id(config) not in made:
            others = unnamed(config) if config is not None else {}
            made[id(config)] = RowConfig(str(folder), config, others)
        row[ROW_CONFIG] = made[id(config)]


def _config(row: dict) -> dict:
    recorded = row.get(ROW_CONFIG)
    return recorded.config if recorded is not None and recorded.config is not None else {}


def _robots(row: dict) -> int:
    n = number(row.get("robots"))
    if n is not None:
        return int(n)
    robots = _config(row).get("robots")
    return len(robots) if isinstance(robots, list) and robots else 1  # blank: one robot


def _coordination(row: dict) -> str:
    if _robots(row) < 2:
        return ""
    return row.get("coordination") or str(_config(row).get("coordination", ""))


def _catalogue(row: dict) -> str:
    config = _config(row)
    if "catalogue" not in config:
        return ""
    return str(config["catalogue"]) or "built-in"


def _cup(row: dict) -> tuple:
    """(diameter [m], vacuum [Pa]) of the cup the episode ran with: the manifest's, a diameter
    left unset (null) being the default for its robot count."""
    cup = _config(row).get("cup")
    if not isinstance(cup, dict):
        return ()
    diameter = number(cup.get("diameter_m"))
    if diameter is None and "diameter_m" in cup:  # unset: the default the episode ran with
        diameter = default_cup_diameter_m(int(number(row.get("robots")) or 1))
    vacuum = number(cup.get("vacuum_pa"))
    return (
        math.nan if diameter is None else diameter,
        math.nan if vacuum is None else vacuum,
    )


def _belt_width(row: dict) -> float:
    belt = _config(row).get("belt")
    width = number(belt.get("width_m")) if isinstance(belt, dict) else None
    return BELT_WIDTH_M if width is None else width  # recorded before the key: the thesis's


def _energy_price(row: dict) -> float:
    price = number(row.get("energy_price_eur_per_kwh"))
    if price is None:
        price = number(_config(row).get("energy_price_eur_per_kwh"))
    return price or 0.0


def _economics(row: dict) -> tuple:
    values = [number(row.get(c)) for c in ECONOMICS_COLUMNS]
    if None in values:
        table = _config(row).get("economics")
        values = (
            [number(table.get(c)) for c in ECONOMICS_COLUMNS] if isinstance(table, dict) else []
        )
    return tuple(values) if values and None not in values else ()


def _feed(row: dict) -> float:
    density = number(row.get("items_per_m"))
    duration = number(_config(row).get("duration_s"))
    if density is None and duration:
        density = int(row["n_items"]) / (duration * SPEED_X1_MPS * float(row["speed_factor"]))
    return round(density, 3) if density is not None else -1.0


@dataclass(frozen=True)
class Setting:
    """A setting a report groups by.

    Attributes:
        name: Its name in a `Point`.
        label: Its table column's heading.
        of: Its value of an episode (row).
        cell: Its value as a table cell.
        said: Its value in words, when every episode has it (empty: not said).
        shown: A table column even when every episode has the same value.
    """

    name: str
    label: str
    of: Callable[[dict], Any]
    cell: Callable[[Any], str]
    said: Callable[[Any], str]
    shown: bool = False


def _cup_text(cup: tuple) -> str:
    return f"{cup[0] * 1000:g} mm, {cup[1] / 1000:g} kPa" if cup else "-"


def _economics_text(e: tuple) -> str:
    if not e:
        return "-"
    return f"{e[0] / 1000:g} kEUR, {e[1]:g} y, {e[2]:g} h/y, {e[3]:g} EUR/y"


def _if(value: Any, text: str) -> str:
    return text if value not in ("", (), -1.0) else ""


SETTINGS = (
    Setting(
        "code", "code", lambda r: r.get("code_digest") or "", lambda v: v[:12] or "-",
        lambda v: _if(v, f"code {v[:12]}"),
    ),
    Setting(
        "catalogue", "catalogue", _catalogue, lambda v: Path(v).name if v else "-",
        lambda v: _if(v, f"catalogue {Path(v).name}"),
    ),
    Setting(
        "variant", "variant", lambda r: r.get("variant") or "base", str,
        lambda v: f"variant {v}",
    ),
    Setting(
        "perception", "perception", lambda r: r.get("perception") or "", lambda v: v or "-",
        lambda v: _if(v, f"{v} perception"),
    ),
    Setting(
        "robots", "robots", _robots, str, lambda v: f"{v} robot" + "s" * (v != 1),
    ),
    Setting(
        "coordination", "coordination", _coordination, lambda v: v or "-",
        lambda v: _if(v, f"coordination {v}"),
    ),
    Setting("cup", "cup", _cup, _cup_text, lambda v: _if(v, f"cup {_cup_text(v)}")),
    Setting(
        "width", "belt width", _belt_width, lambda v: f"{v:g} m",
        lambda v: f"belt {v:g} m wide" if v != BELT_WIDTH_M else "",
    ),
    Setting(
        "energy_price", "energy EUR/kWh", _energy_price, lambda v: f"{v:g}",
        lambda v: f"energy {v:g} EUR/kWh" if v else "",
    ),
    Setting(
        "economics", "robot economics", _economics, _economics_text,
        lambda v: _if(v, f"robot economics {_economics_text(v)}"),
    ),
    Setting(
        "speed", "belt", lambda r: round(float(r["speed_factor"]), 3), lambda v: f"x{v:g}",
        lambda v: "", shown=True,
    ),
    Setting(
        "items", "items", lambda r: int(r["n_items"]), str, lambda v: "", shown=True,
    ),
    Setting(
        "feed", "items/m", _feed, lambda v: "-" if v < 0 else f"{v:.1f}", lambda v: "",
    ),
    Setting("planner", "planner", lambda r: r["planner"], str, lambda v: "", shown=True),
)  # fmt: skip
"""Every setting a report groups by, in the order its tables give them."""
INDEX = {s.name: k for k, s in enumerate(SETTINGS)}


@dataclass(frozen=True, order=True)
class Point:
    """A grid point: the value of every grouping setting, in `SETTINGS` order."""

    values: tuple

    def __getitem__(self, name: str) -> Any:
        return self.values[INDEX[name]]

    def replace(self, **changes: Any) -> Point:
        """The point with some settings changed (`without` planner: planner="")."""
        values = list(self.values)
        for name, value in changes.items():
            values[INDEX[name]] = value
        return Point(tuple(values))


def point_of(row: dict) -> Point:
    """The grid point of an episodes.csv row (with its `RowConfig`, when it has one)."""
    return Point(tuple(s.of(row) for s in SETTINGS))


def varying(points) -> list[str]:
    """The settings (names) whose values differ over `points`: the grouping columns. The
    feed counts only where it differs at the same items and belt speed (a flow of another
    length); a line's coordination only among lines."""
    points = list(points)
    out = []
    for s in SETTINGS:
        if s.name == "feed":
            by = defaultdict(set)
            for p in points:
                by[(p["items"], p["speed"])].add(p["feed"])
            differs = any(len(v) > 1 for v in by.values())
        elif s.name == "coordination":
            differs = len({p["coordination"] for p in points if p["robots"] > 1}) > 1
        else:
            differs = len({p[s.name] for p in points}) > 1
        if differs:
            out.append(s.name)
    return out


@dataclass(frozen=True)
class GridColumns:
    """Which settings a table shows before its planner column: those that differ over the
    report's episodes, and the belt and items always.

    Attributes:
        names: The settings shown, in `SETTINGS` order (the planner aside).
    """

    names: tuple[str, ...]

    @classmethod
    def of(cls, points) -> GridColumns:
        """The columns of `points`."""
        differ = set(varying(points))
        names = tuple(
            s.name for s in SETTINGS if s.name != "planner" and (s.shown or s.name in differ)
        )
        return cls(names)

    def head(self) -> list[str]:
        """The header cells."""
        return [SETTINGS[INDEX[n]].label for n in self.names]

    def cells(self, point: Point) -> list[str]:
        """The cells of `point`."""
        return [SETTINGS[INDEX[n]].cell(point[n]) for n in self.names]

    def where(self, point: Point) -> str:
        """The point in words for a note ("x1.5, 40 items", the other columns before)."""
        parts = []
        for name, cell in zip(self.names, self.cells(point), strict=True):
            parts.append(f"{cell} items" if name == "items" else cell)
        return ", ".join(parts)


def constant_text(points) -> str:
    """'Every episode: variant base, truth perception, 1 robot, ...' for the settings that are
    the same over every episode and no table shows."""
    points = list(points)
    if not points:
        return ""
    differ = set(varying(points))
    parts = []
    for s in SETTINGS:
        if s.shown or s.name in differ:
            continue
        if s.name == "coordination":
            lines = {p["coordination"] for p in points if p["robots"] > 1}
            text = s.said(next(iter(lines))) if len(lines) == 1 else ""
        else:
            text = s.said(points[0][s.name])
        if text:
            parts.append(text)
    return f"Every episode: {', '.join(parts)}." if parts else ""


def grouping_text(points) -> str:
    """The grouping columns in words: 'Grouped by robots, planner: the settings in which the
    episodes differ.'"""
    names = varying(points)
    if not names:
        return "Grouped by nothing: every episode has the same settings."
    labels = ", ".join(SETTINGS[INDEX[n]].label for n in names)
    return f"Grouped by {labels}: the settings in which the episodes differ."


def _csv_others(row: dict) -> dict[str, str]:
    out = {k: str(v) for k, v in row.items() if k.startswith("variant.")}
    if row.get("min_class_confidence") not in (None, ""):
        out["min_class_confidence"] = str(row["min_class_confidence"])
    return out


def others(row: dict) -> dict[str, str]:
    """The settings of a row that no grouping setting stands for ({key: value as text})."""
    recorded = row.get(ROW_CONFIG)
    return {**(recorded.others if recorded is not None else {}), **_csv_others(row)}


def _folder(row: dict) -> str:
    recorded = row.get(ROW_CONFIG)
    return recorded.folder if recorded is not None else "its folder"


def check_groups(rows: list[dict]) -> None:
    """Refuse, in one line, a group of episodes (one grid point) whose settings differ in one
    that no grouping setting stands for (the first such key, the two values, their folders)."""
    groups: dict[Point, list[dict]] = defaultdict(list)
    for row in rows:
        groups[point_of(row)].append(row)
    grid = GridColumns.of(groups)
    for point, members in sorted(groups.items()):
        seen: dict[str, tuple[str, str]] = {}
        for row in members:
            for key, value in sorted(others(row).items()):
                first = seen.setdefault(key, (value, _folder(row)))
                if first[0] != value:
                    names = ", ".join(s.label for s in SETTINGS)
                    allowed = (
                        f"one value within each group the report averages (it groups by "
                        f"{names}; report episodes that differ in {key} separately, or run them "
                        "as variants of one sweep)"
                    )
                    got = f"{first[0]} in {first[1]}, {value} in {_folder(row)}"
                    where = f"{grid.where(point)}, {point['planner']}"
                    raise InvalidInput(key, allowed, got, where)


def differing_elsewhere(rows: list[dict]) -> list[str]:
    """The settings no grouping setting stands for that differ between groups (never within
    one: `check_groups`), to be named under the tables."""
    values: dict[str, set[str]] = defaultdict(set)
    for row in rows:
        for key, value in others(row).items():
            values[key].add(value)
    return sorted(k for k, v in values.items() if len(v) > 1 and not k.startswith("variant."))
