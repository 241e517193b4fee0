"""docs/settings.md, generated from the episode config: every key, its default, range, unit and
meaning.

    python -m sim.experiments.settings_doc            # writes docs/settings.md
    python -m sim.experiments.settings_doc --check    # exit 1 if the file is not up to date

Nothing is written by hand: the keys are the fields of the config's schema (`sim.config`:
`EpisodeSettings`' top-level keys, its tables `SECTIONS`: `[video]`, `[camera]`, ...; the robots'
`RobotSpec` and the old `[robot]` section, `sim.config.migration`), the defaults those
dataclasses' (the world's numbers: the `varied` and `uniform` presets'), the ranges each field's
`Setting` (`sim.config.fields`), else what the config's own validation answers when the key is
given a value it refuses (each refusal's "allowed" text: the range cannot drift from the
checks), the meanings the comments of the config's TOML layout (`sim.config`'s docstring, for
the top-level keys) or the dataclasses' `Attributes:` docstrings, and the units the `Setting`'s
`unit`, else the `[unit]` those texts give, else the key's suffix (`_s`, `_m`, `_pa`, ...).
`tests/test_settings_doc.py` checks that the committed file is the generated one.
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import re
import sys
from pathlib import Path
from typing import Any

import sim.config
from sim.config import migration
from sim.config.episode import SCALARS, SECTIONS, EpisodeConfig
from sim.config.faults import FAULT_KINDS, KIND_KEYS, RANDOM_KEYS, Fault, RandomFaults
from sim.config.fields import SETTING, Setting
from sim.config.loading import from_dict
from sim.config.plant import CUP_DIAMETER_M, LINE_CUP_DIAMETER_M
from sim.config.robots import SECTION_KEYS, RobotSpec
from sim.config.sections import Surges
from sim.config.settings import ITEM_CLASSIFIER_MIN_CONFIDENCE, WORLD_NUMBERS
from sim.config.values import Values
from sim.errors import InvalidInput
from sim.flow.feed_rate import FEED_KEYS
from sim.flow.world import WorldVariation
from sim.paths import REPO_ROOT

OUT = REPO_ROOT / "docs" / "settings.md"
PROBES = (-1e30, "\0?", [-1e30])
"""Values tried in turn until the validation refuses one (a number far out of every range, a
string no key takes, a list)."""
SUFFIX_UNITS = (
    ("_eur_per_kwh", "EUR/kWh"),
    ("_deg", "deg"),
    ("_pa", "Pa"),
    ("_s", "s"),
    ("_m", "m"),
)
UNIT = re.compile(
    r"\[(m|s|px|Pa|EUR|deg|m/s|EUR/kWh|EUR/kg|EUR/year|J|kg|years|h/year|items/m|items/s|kg/h)\]"
)
REGENERATE = "python -m sim.experiments.settings_doc"
UNCOMMENTED = {
    "seed": "The episode's seed: the flow (times, places, classes, items), the world's "
    "variation, the depth noise and the planners' random draws; the same seed and config give "
    "the same CSVs.",
    "items": "Items dropped on the belt over `duration_s` (or the feed in plant units: "
    "`[infeed]`, not both).",
}
"""Meanings of the top-level keys the config's TOML layout gives without a comment."""
UNSET = {
    "horizon_s": "unset: the run ends once every item has arrived and left the belt",
    "belt.speed_mps": "unset: speed_factor's (0.185 m/s at x1)",
    **{f"infeed.{k}": "unset: `items` over `duration_s`" for k in FEED_KEYS},
    "flow.mix_types": "unset: the catalogue's weights within each material",
    "economics.energy_price_eur_per_kwh": "the top-level `energy_price_eur_per_kwh` (0)",
    "cup.diameter_m": f"{CUP_DIAMETER_M:g} (one robot), {LINE_CUP_DIAMETER_M:g} (a line of 2-4)",
    "infeed.surges": "unset: no surges",
    **{f"infeed.surges.{k}": "required in a surges table" for k in Surges.__dataclass_fields__},
}
"""Defaults of keys that are unset (None) unless given, in words (`flow.mix`'s: `default_mix`)."""


def default_mix() -> str:
    """The default flow's material shares: the stationary distribution of its transitions,
    what long flows carry (`EpisodeConfig.material_shares`)."""
    config = EpisodeConfig()
    shares = ", ".join(
        f"{n} {s:.3f}" for n, s in zip(config.materials.names, config.material_shares, strict=True)
    )
    return (
        f"{shares}: the default transitions' stationary shares, which long flows carry "
        '(measured: docs/episode.md, "The feed in plant units"); equal shares for a catalogue '
        "of other materials"
    )


SECTION_TEXT = {
    "[values]": "A plant prices its bales by the kilogram: `[values] per_kg = { paper = 0.10, "
    "plastic = 0.30, aluminium = 1.20 }` (EUR/kg; an illustration of the order of European bale "
    "prices, which move month to month: set the plant's own). The per-item defaults are the "
    "thesis's, far above a small item's scrap value.",
    "[[faults]] and [faults_random]": "Faults over the episode (`sim/config/faults.py`): "
    "given one by one, a `[[faults]]` table each (`kind`, `start_s`, `duration_s` and the "
    "kind's own key), or drawn from the seed, a `[faults_random.<kind>]` table per kind "
    "(`mtbf_s`, `mttr_s` and the kind's own key but `robot` or `camera`: every robot and "
    "camera draws its own). Two faults of one kind on one part may not overlap; a fault naming "
    "a robot or camera the cell lacks or starting at or after the episode's end (`horizon_s`, "
    "else `duration_s`) is refused when the config loads. Kinds and their keys: "
    + "; ".join(f"{k}: {', '.join(v) or 'none'}" for k, v in KIND_KEYS.items())
    + ".",
    "[economics]": "Assumptions for one delta robot cell, to be replaced by the plant's own "
    "figures; they change no episode, only the money columns of episodes.csv "
    "(`robot_cost_per_h_eur` = robots x (capital / (life x hours per year) + maintenance / "
    "hours per year): 2.625 EUR/h per robot at the defaults) and the report's payback "
    "(`docs/report.md`).",
}
"""A paragraph under a section's heading (what its defaults assume)."""


@dataclasses.dataclass(frozen=True)
class Row:
    """One key of the episode config, as the settings reference lists it."""

    key: str
    default: str
    allowed: str
    unit: str
    meaning: str


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _toml(value: Any) -> str:
    """A default as a config file writes it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, tuple | list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def layout_comments() -> dict[str, str]:
    """{top-level key: its comment} from the config's TOML layout (`sim.config`'s docstring's
    block before its first table), continuation lines joined."""
    out: dict[str, str] = {}
    key = None
    for line in (sim.config.__doc__ or "").splitlines():
        stripped = line.strip()
        if stripped.startswith("["):
            if key is not None:
                break
            continue
        match = re.match(r"^\s{4}(\w+)\s*=\s*[^#]*#\s?(.*)$", line)
        if match:
            key = match.group(1)
            out[key] = match.group(2).strip()
        elif key is not None and stripped.startswith("#"):
            out[key] += " " + stripped.lstrip("#").strip()
        elif stripped and key is not None and not line.startswith("    "):
            break
    return out


def attribute_docs(cls: type) -> dict[str, str]:
    """{attribute: its text} of a class's Google-style `Attributes:` section."""
    doc = inspect.getdoc(cls) or ""
    out: dict[str, str] = {}
    inside, name = False, None
    for line in doc.splitlines():
        if line.strip() == "Attributes:":
            inside = True
            continue
        if not inside:
            continue
        match = re.match(r"^    (\w+):\s*(.*)$", line)
        if match:
            name = match.group(1)
            out[name] = match.group(2).strip()
        elif line.startswith("        ") and name:
            out[name] += " " + line.strip()
        elif line.strip() and not line.startswith("    "):
            break
    return out


def allowed_of(field: dataclasses.Field, data: dict[str, Any], key: str) -> str:
    """What the config allows for `key`: its `Setting`'s words when it checks them itself,
    else what its refusal says (`refusal`)."""
    spec: Setting | None = field.metadata.get(SETTING)
    checked_here = spec is not None and (spec.range is None or not spec.range.checked_by)
    if checked_here and spec is not None and spec.allowed:
        return spec.allowed
    return refusal(data, key)


def refusal(data: dict[str, Any], field: str) -> str:
    """What the config allows for `field`: the "allowed" text of its refusal of the first of
    `PROBES` it refuses (`data` builds the config with `{PROBE}` in place of the value)."""
    for probe in PROBES:
        try:
            from_dict(_put(data, probe))
        except InvalidInput as exc:
            if exc.field.split("[")[0] == field.split("[")[0] or exc.field == field:
                return exc.allowed
    return "-"


def _put(data: Any, probe: Any) -> Any:
    if data is ...:
        return probe
    if isinstance(data, dict):
        return {k: _put(v, probe) for k, v in data.items()}
    if isinstance(data, list):
        return [_put(v, probe) for v in data]
    return data


def unit_of(key: str, *texts: str, field: dataclasses.Field | None = None) -> str:
    """The unit of a key: its `Setting`'s, else the one its texts give in brackets, else its
    suffix's, else '-'."""
    spec = field.metadata.get(SETTING) if field is not None else None
    if spec is not None and spec.unit:
        return spec.unit
    for text in texts:
        match = UNIT.search(text or "")
        if match:
            return match.group(1)
    name = key.split(".")[-1]
    for suffix, unit in SUFFIX_UNITS:
        if name.endswith(suffix):
            return unit
    return "-"


def _scalars() -> list[Row]:
    comments = layout_comments()
    world = attribute_docs(WorldVariation)
    varied, uniform = WorldVariation(), WorldVariation.uniform()
    defaults = EpisodeConfig.__dataclass_fields__
    out = []
    for name in SCALARS:
        field = defaults[name]
        if name in WORLD_NUMBERS:
            a, b = getattr(varied, name), getattr(uniform, name)
            default = f"the world's: {_toml(a)} (varied), {_toml(b)} (uniform)"
            meaning = world.get(name, comments.get(name, ""))
        elif name == "robots":
            default, meaning = "1", comments.get(name, "")
        elif name == "min_class_confidence":
            threshold = f"{ITEM_CLASSIFIER_MIN_CONFIDENCE:g}"
            default = f"the classifier's: {threshold} (fused, features), 0 (hmm; truth perception)"
            meaning = comments.get(name, "")
        else:
            default = UNSET[name] if field.default is None else _toml(field.default)
            meaning = comments.get(name) or UNCOMMENTED.get(name, "")
        allowed = allowed_of(field, {name: ...}, name)
        unit = unit_of(name, meaning, allowed, field=field)
        out.append(Row(name, default, allowed, unit, meaning))
    return out


def _section(name: str, cls: type) -> list[Row]:
    docs = attribute_docs(cls)
    out = []
    for field in dataclasses.fields(cls):
        key = f"{name}.{field.name}"
        default = field.default
        if default is dataclasses.MISSING:
            default = field.default_factory() if callable(field.default_factory) else None
        default_text = _toml(default)
        if default is None:
            default_text = UNSET.get(key, "the default mix (thesis's)")
            default_text = default_mix() if key == "flow.mix" else default_text
        allowed = allowed_of(field, {name: {field.name: ...}}, key)
        meaning = docs.get(field.name, "")
        unit = unit_of(key, meaning, allowed, field=field)
        out.append(Row(key, default_text, allowed, unit, meaning))
    return out


def _values() -> list[Row]:
    doc = " ".join((inspect.getdoc(Values) or "").split("Attributes:")[0].split())
    prices = EpisodeConfig().values.given()
    default = ", ".join(f"{k} {v:g}" for k, v in prices.items())
    allowed = refusal({"values": {"paper": ...}}, "values.paper")
    per_kg = refusal({"values": {"per_kg": {"paper": ...}}}, "values.per_kg.paper")
    meaning = (
        "Value of an item per kilogram of its own mass (as the world varied its size) [EUR/kg], "
        "by material or item type, instead of its value per item (see above). Unset: every "
        "item is valued per item."
    )
    return [
        Row("values.<material or item type>", default, allowed, "EUR", doc),
        Row("values.per_kg.<material or item type>", "unset", per_kg, "EUR/kg", meaning),
    ]


def _robots() -> list[Row]:
    docs = attribute_docs(RobotSpec)
    out = []
    spec = RobotSpec()
    for field in dataclasses.fields(RobotSpec):
        name = field.name
        default = getattr(spec, name)
        default_text = {"x_m": "0, 1.8, 3.6, ... (the line's spacing)", "materials": "every"}
        text = default_text.get(name, _toml(default))
        allowed = refusal({"robots": [{name: ...}]}, f"robots[0].{name}")
        if allowed == "-":
            allowed = refusal({"robots": [{name: ...}]}, f"robots.{name}")
        meaning = docs.get(name, "")
        out.append(
            Row(f"[[robots]] {name}", text, allowed, unit_of(name, meaning, allowed), meaning)
        )
        if name in SECTION_KEYS:
            key = f"{migration.SECTION}.{name}"
            allowed = refusal({migration.SECTION: {name: ...}}, key)
            meaning = (
                f"An old file's every robot's default of `[[robots]] {name}` (a table's own "
                "key wins; read by `sim.config.migration`)."
            )
            out.append(Row(key, text, allowed, unit_of(name, allowed), meaning))
    return out


FAULT_DEFAULTS = {
    "kind": "required",
    "start_s": "required",
    "duration_s": "required",
    "robot": "required (robot_stop)",
    "camera": "unset: every camera",
    "vacuum_pa": "required (vacuum_drop)",
    "speed_factor": "required (belt_speed)",
    "mtbf_s": "required",
    "mttr_s": "required",
}
"""The faults' keys' defaults, in words."""


def _kind_of(key: str) -> str:
    """The fault kind whose table a key is probed in (its own kind's, else belt_stop)."""
    return next((k for k, keys in KIND_KEYS.items() if key in keys), "belt_stop")


def _faults() -> list[Row]:
    out = []
    docs = attribute_docs(Fault)
    for f in dataclasses.fields(Fault):
        kind = _kind_of(f.name) if f.name != "kind" else FAULT_KINDS[0]
        table = {
            "kind": kind,
            "start_s": 0.0,
            "duration_s": 1.0,
            **dict.fromkeys(KIND_KEYS[kind], 0),
        }
        field = "faults.kind" if f.name == "kind" else f"faults.{kind}.{f.name}"
        allowed = refusal({"faults": [{**table, f.name: ...}]}, field)
        meaning = docs.get(f.name, "")
        unit = unit_of(f.name, meaning, allowed)
        out.append(Row(f"[[faults]] {f.name}", FAULT_DEFAULTS[f.name], allowed, unit, meaning))
    docs = attribute_docs(RandomFaults)
    for f in dataclasses.fields(RandomFaults)[1:]:
        kind = _kind_of(f.name)
        table = {"mtbf_s": 1.0, "mttr_s": 1.0, **dict.fromkeys(RANDOM_KEYS[kind], 0.5)}
        field = f"faults_random.{kind}.{f.name}"
        allowed = refusal({"faults_random": {kind: {**table, f.name: ...}}}, field)
        meaning = docs.get(f.name, "")
        key = f"[faults_random.<kind>] {f.name}"
        out.append(Row(key, FAULT_DEFAULTS[f.name], allowed, unit_of(f.name, meaning), meaning))
    return out


def settings() -> list[tuple[str, list[Row]]]:
    """The settings reference's tables: (heading, settings) per part of the config."""
    parts = [("Top-level keys", _scalars()), ("[values]", _values())]
    for name, cls in SECTIONS.items():
        if name != "values":
            parts.append((f"[{name}]", _section(name, cls)))
        if name == "infeed":
            parts[-1][1].extend(_section("infeed.surges", Surges))
    parts.append(("[robot] and [[robots]]", _robots()))
    parts.append(("[[faults]] and [faults_random]", _faults()))
    return parts


def markdown() -> str:
    """docs/settings.md's text."""
    lines = [
        "# Episode settings reference",
        "",
        f"Generated from the config's schema (`sim/config/`) by `{REGENERATE}` (do not edit "
        "by hand; `tests/test_settings_doc.py` checks the file is up to date). Every key a "
        "config file (`sortsim run --config FILE`, a sweep's `[base]` and `[[variants]]`) may "
        "hold; command-line options override them (`sortsim run --help`). *Allowed* is what the "
        "config's validation answers when it refuses a value (so it cannot drift from the "
        "checks); a refused value stops the command with that line before anything runs "
        "(exit code 2). The layout of a file, with examples, is in `sim/config/__init__.py`'s "
        "docstring; `docs/episode.md` says what the settings change.",
        "",
    ]
    for heading, rows in settings():
        lines += [f"## {heading}", ""]
        lines += [SECTION_TEXT[heading], ""] if heading in SECTION_TEXT else []
        lines += ["| key | default | allowed | unit | meaning |", "|---|---|---|---|---|"]
        for s in rows:
            cells = [f"`{s.key}`", s.default, s.allowed, s.unit, s.meaning]
            lines.append("| " + " | ".join(_cell(c) for c in cells) + " |")
        lines.append("")
    return "\n".join(lines + environment())


def environment() -> list[str]:
    """The section of the environment variables the commands read beside a config."""
    from sim import user_cache

    cells = (f"`{user_cache.VARIABLE}`", user_cache.DEFAULT_TEXT, user_cache.ALLOWED)
    return [
        "## Environment",
        "",
        "Read beside the config (camera perception's caches: `sortsim run`, `sweep`, `view`, "
        "`frames`); a value refused stops the command before any episode, in one line naming "
        "the variable.",
        "",
        "| variable | default | allowed | meaning |",
        "|---|---|---|---|",
        "| " + " | ".join(_cell(c) for c in (*cells, user_cache.MEANING)) + " |",
        "",
    ]


def main(argv: list[str] | None = None) -> int:
    """Write docs/settings.md (or, with --check, say whether it is up to date)."""
    parser = argparse.ArgumentParser(prog="python -m sim.experiments.settings_doc")
    parser.add_argument("--out", type=Path, default=OUT, help="where to write (docs/settings.md)")
    parser.add_argument("--check", action="store_true", help="exit 1 if the file differs")
    args = parser.parse_args(argv)
    text = markdown()
    if args.check:
        current = args.out.read_text(encoding="utf-8") if args.out.is_file() else ""
        if current != text:
            print(f"{args.out} is not up to date: run {REGENERATE}", file=sys.stderr)
            return 1
        return 0
    args.out.write_text(text, encoding="utf-8")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
