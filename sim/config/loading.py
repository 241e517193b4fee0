"""Reading an episode config: a TOML file or a run's manifest.json (`read_config_file`), its
old layouts brought up to date (`sim.config.migration`), the catalogue file read, the options
of the command line applied (`load`), validated in one line per refusal (`InvalidInput`)."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from sim.checks import check
from sim.config.catalogue_file import CatalogueFile, episode_catalogue
from sim.config.episode import FAULT_KEYS, SCALARS, SECTIONS, EpisodeConfig
from sim.config.faults import faults_of_tables, random_faults_of_table
from sim.config.fields import check_keys
from sim.config.migration import SECTION as OLD_ROBOT_SECTION
from sim.config.migration import migrated
from sim.config.robots import robot_specs
from sim.config.values import Values
from sim.errors import InvalidInput
from sim.flow.feed_rate import FEED_KEYS

KEYS = (*SCALARS, *SECTIONS, *FAULT_KEYS, OLD_ROBOT_SECTION)
"""Every top-level key of a config file (`robot`: an old file's section of every robot's
pauses, `sim.config.migration`)."""


def from_dict(data: dict[str, Any], where: str | None = None) -> EpisodeConfig:
    """An `EpisodeConfig` from a TOML-shaped dict (a config file's, a manifest's `config`, a
    sweep's grid point), its catalogue file read here.

    Args:
        data: The settings in the TOML layout (module docstring); `robots` a count or an array
            of tables, `[robot]` every robot's defaults.
        where: The file they came from, named by every refusal.

    Returns:
        The validated config.

    Raises:
        InvalidInput: One line naming the key (an unknown one too) and `where`.
    """
    try:
        return _from_dict(data, where)
    except InvalidInput as exc:
        if exc.where is None and where is not None:
            raise InvalidInput(exc.field, exc.allowed, exc.got, where) from None
        raise


def _from_dict(data: dict[str, Any], where: str | None) -> EpisodeConfig:
    data = migrated(data, where)
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        if key in SECTIONS:
            cls = SECTIONS[key]
            check(isinstance(value, dict), key, "a table [" + key + "]", value, where)
            if cls is Values:
                kwargs[key] = Values.from_table(value)
                continue
            check_keys(cls, value, f"{key}.", where)
            kwargs[key] = cls(**value)
        elif key == "faults":
            kwargs[key] = faults_of_tables(value, where)
        elif key == "faults_random":
            kwargs[key] = random_faults_of_table(value, where)
        else:
            check(key in SCALARS, key, "one of " + ", ".join(sorted(KEYS)), None, where)
            kwargs[key] = value
    if "robots" in kwargs:
        kwargs["robots"] = robot_specs(kwargs["robots"], where)
    kwargs["catalogue_file"] = CatalogueFile.read(kwargs.get("catalogue", ""), where)
    config = EpisodeConfig(where=where, **kwargs)
    _check_one_spelling(data, config, where)
    return config


def _check_one_spelling(data: dict[str, Any], config: EpisodeConfig, where: str | None) -> None:
    """Refuse a file that gives the belt's speed or the feed twice, in both units (the config
    itself refuses any other value than the one that follows; here also the default's value
    written out, `speed_factor = 1.0` beside `[belt] speed_mps = 0.2`, and the one that
    follows)."""
    v = config.belt.speed_mps
    if "speed_factor" in data and v is not None:
        allowed = "unset when belt.speed_mps is given (one belt speed: "
        allowed += f"{v:g} m/s is x{config.speed_factor:.4g})"
        raise InvalidInput("speed_factor", allowed, data["speed_factor"], where)
    rate = config.infeed.rate
    if "items" in data and rate is not None:
        allowed = f"unset when infeed.{rate[0]} is given (one feed: {rate[1]:g} gives "
        allowed += f"{config.items} items)"
        raise InvalidInput("items", allowed, data["items"], where)


def read_config_file(path: Path) -> dict[str, Any]:
    """The settings of a config file: a TOML file, or a run folder's `manifest.json` (its
    resolved `config`), so that `sortsim run --config runs/x/manifest.json` repeats that run.

    Args:
        path: The TOML file or manifest.json.

    Returns:
        The settings in the TOML layout (for `from_dict`).

    Raises:
        InvalidInput: One line naming the file when it cannot be read or is not a run's
            manifest, or `catalogue` when the manifest's catalogue's content has changed
            since the run (`catalogue_digest`).
    """
    path = Path(path)
    if path.suffix.lower() != ".json":
        return read_toml(path)
    import json

    try:
        manifest = json.loads(path.read_bytes().decode("utf-8"))
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise InvalidInput(
            "config", "a readable TOML file or manifest.json", reason, str(path)
        ) from None
    except (UnicodeDecodeError, ValueError) as exc:
        reason = " ".join(str(exc).split())[:120]
        raise InvalidInput("config", "a run's manifest.json (JSON)", reason, str(path)) from None
    ok = isinstance(manifest, dict) and manifest.get("kind") == "run"
    if not ok or not isinstance(manifest.get("config"), dict):
        got = manifest.get("kind") if isinstance(manifest, dict) else type(manifest).__name__
        allowed = "a run's manifest.json (kind run, with its config); a sweep is repeated "
        allowed += "from its TOML"
        raise InvalidInput("config", allowed, got, str(path))
    data = manifest["config"]
    digest = manifest.get("catalogue_digest")
    if digest is not None:
        now = episode_catalogue(str(data.get("catalogue", ""))).digest
        if now != digest:
            allowed = f"the catalogue the run had (content digest {digest})"
            raise InvalidInput("catalogue", allowed, f"changed since (now {now})", str(path))
    return data


def _without_economics_price(data: dict[str, Any]) -> dict[str, Any]:
    """`data` without its `[economics]` energy price (the other keys as they are)."""
    economics = data.get("economics")
    if not isinstance(economics, dict) or "energy_price_eur_per_kwh" not in economics:
        return data
    rest = {k: v for k, v in economics.items() if k != "energy_price_eur_per_kwh"}
    return {**data, "economics": rest}


def read_toml(path: Path) -> dict[str, Any]:
    """The parsed TOML of a file.

    Args:
        path: The TOML file.

    Returns:
        Its tables as dicts.

    Raises:
        InvalidInput: One line naming the file when it is missing, unreadable, not UTF-8 or
            not valid TOML.
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise InvalidInput("config", "a readable TOML file", reason, str(path)) from None
    except UnicodeDecodeError as exc:
        got = f"not UTF-8 at byte {exc.start}"
        raise InvalidInput("config", "a UTF-8 TOML file", got, str(path)) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        reason = " ".join(str(exc).split())
        raise InvalidInput("config", f"valid TOML ({reason})", None, str(path)) from None


SECTION_OPTIONS = {
    "belt_speed_mps": ("belt", "speed_mps"),
    "items_per_m": ("infeed", "items_per_m"),
}
"""`load`'s keywords that set a section's key (the plant units of `sortsim run`'s options)."""
SPELLINGS = (
    ("speed_factor", "belt.speed_mps"),
    ("items", *(f"infeed.{k}" for k in FEED_KEYS)),
)
"""Keys that say the same thing in other units: an option setting one of a group takes the
file's others away (the belt's speed; the feed)."""


def _with_options(data: dict[str, Any], changes: dict[str, Any]) -> dict[str, Any]:
    """The settings of a file with the options applied: each option's key set (a section's
    inside its table), the file's keys of the same group of `SPELLINGS` taken away.

    Args:
        data: The file's settings (not changed).
        changes: {`load` keyword: value}.

    Returns:
        A new dict of settings.
    """
    out = {k: dict(v) if isinstance(v, dict) else v for k, v in data.items()}
    for name, value in changes.items():
        key = ".".join(SECTION_OPTIONS.get(name, (name,)))
        for group in SPELLINGS:
            for other in group if key in group else ():
                section, _, sub = other.rpartition(".")
                table = out.get(section) if section else out
                if isinstance(table, dict):
                    table.pop(sub, None)
        section, _, sub = key.rpartition(".")
        if not section:
            out[key] = value
        elif isinstance(out.setdefault(section, {}), dict):  # else the file's error, refused
            out[section][sub] = value
    return out


def load(path: Path | None = None, **overrides: Any) -> EpisodeConfig:
    """The episode config of a config file (or the defaults) with the options given applied.

    Args:
        path: A TOML file or a run's manifest.json (`read_config_file`); None: the defaults.
        **overrides: Top-level keys to set (the command line's options); None leaves a key
            as the file has it. `robots = N` gives N robots at the default spacing keeping
            the file's pauses (`EpisodeConfig.replace`); the others take the file's keys'
            place before anything is validated, so what depends on several keys (the
            materials' values on the catalogue, the catalogue's items on the world's variation)
            is checked with the options applied; `catalogue` is read here.

    Returns:
        The validated config (`where` None once options changed it).

    Raises:
        InvalidInput: One line naming the key and the file.
    """
    data = read_config_file(path) if path is not None else {}
    where = str(path) if path is not None else None
    changes = {k: v for k, v in overrides.items() if v is not None}
    unknown = set(changes) - set(SCALARS) - set(SECTION_OPTIONS)
    options = ", ".join(sorted(set(SCALARS) | set(SECTION_OPTIONS)))
    check(not unknown, "override", options, sorted(unknown), None)
    if not changes:
        return from_dict(data, where)
    robots = changes.pop("robots", None)  # a count keeps the file's robots' pauses: replace
    if "energy_price_eur_per_kwh" in changes:  # the option's price wins over [economics]'
        data = _without_economics_price(data)
    keys = {".".join(SECTION_OPTIONS.get(k, (k,))) for k in changes}
    try:
        config = from_dict(_with_options(data, changes), where)
    except InvalidInput as exc:
        if exc.field in keys:  # the option's value: not the file's
            raise InvalidInput(exc.field, exc.allowed, exc.got, None) from None
        raise
    if robots is not None:
        config = config.replace(robots=robots)
    return config.replace(where=None)
