"""The robots of an episode: where each stands, which materials it sorts, how long it dwells.

An episode config's `robots` is a tuple of 1..`MAX_ROBOTS` `RobotSpec`s, upstream first. A
config file gives them in any of three forms, which can be combined:

    robots = 3                          # 3 robots at the default spacing, every material each

    [[robots]]                          # or one table per robot, upstream first
    x_m = 0.0                           # its base centre along the belt [m]
    materials = ["aluminium", "plastic"]  # what it picks; omitted: every material
    pick_pause_s = 0.5                  # extra dwell after the seal [s], 0..2
    [[robots]]
    x_m = 2.0


`x_m` is given for every robot or for none (then 0, 1.8, 3.6, ... m); given, the robots keep
the line model's rules (`sim.model.line_model.LineLayout`): the first at x >= 0, each at least
`MIN_SPACING_M` past the one before, the last at most `MAX_LAST_X_M`. `materials` names the
catalogue's materials, each once; every material must be sorted by at least one robot. A robot
keeps one bin per material of the catalogue whatever it sorts. Each refusal is one line naming
the field (`robots[1].materials`) and what is allowed (`InvalidInput`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from sim.checks import check, is_finite_number, is_integer
from sim.config.fields import Range, setting, validate
from sim.config.plant import MAX_LAST_X_M, MAX_ROBOTS, MIN_SPACING_M
from sim.errors import InvalidInput

if TYPE_CHECKING:
    from perception.codes import Materials

SECTION_KEYS = ("pick_pause_s", "place_pause_s", "idle_sleep")
"""The keys every robot has a value of (an old file's `[robot]` section gave every robot's)."""
ROBOT_KEYS = ("x_m", "materials", *SECTION_KEYS)
"""The keys of one robot's `[[robots]]` table."""
MAX_PAUSE_S = 2.0
"""Longest extra dwell at the pick or the place [s]."""
_PREFIX = "robots."
_COUNT_OR_TABLES = f"1..{MAX_ROBOTS} robots, or an array of 1..{MAX_ROBOTS} [[robots]] tables"
_PAUSE = Range(0.0, MAX_PAUSE_S, f"0..{MAX_PAUSE_S:g} s")


@dataclass(frozen=True)
class RobotSpec:
    """One robot of the episode (of a line, or the single cell's) as the config gives it.

    0 s of pause is the physical robot (ABB's 35 ms of vacuum at each end only). The thesis's
    simulator paused about half a second after each pick and each place (4.2); set both to 0.5
    to reproduce that regime.

    Attributes:
        x_m: x of its base centre along the belt [m]; None: the line's default spacing.
        materials: Names of the materials it sorts, as given (a non-empty tuple, no name
            twice); None: every material of the catalogue.
        pick_pause_s: Extra dwell at the pick, after the seal [s], 0..2.
        place_pause_s: Extra dwell at the place, after the release [s], 0..2.
        idle_sleep: Whether the idle robot sleeps in MuJoCo until its next pick
            (`sim.cell.idle_sleep`); False: the physics to the bit as before the setting.
    """

    x_m: float | None = setting(
        range=Range(0.0, MAX_LAST_X_M, f"0..{MAX_LAST_X_M:g} m", checked_by=__name__)
    )
    materials: tuple[str, ...] | None = None
    pick_pause_s: float = setting(0.0, range=_PAUSE)
    place_pause_s: float = setting(0.0, range=_PAUSE)
    idle_sleep: bool = setting(True, boolean=True)

    def __post_init__(self) -> None:
        x = self.x_m
        check(x is None or is_finite_number(x), f"{_PREFIX}x_m", "a number [m]", x)
        if x is not None:
            object.__setattr__(self, "x_m", float(x))
        validate(self, _PREFIX)
        names = self.materials
        if names is None:
            return
        allowed = "a non-empty list of material names, each once"
        ok = isinstance(names, list | tuple) and bool(names)
        check(ok, f"{_PREFIX}materials", allowed, names)
        ok = all(isinstance(n, str) for n in names) and len(set(names)) == len(names)
        check(ok, f"{_PREFIX}materials", allowed, list(names))
        object.__setattr__(self, "materials", tuple(names))

    def section(self) -> dict[str, Any]:
        """The robot's values of the `[robot]` section's keys (`SECTION_KEYS`).

        Returns:
            {"pick_pause_s": [s], "place_pause_s": [s], "idle_sleep": bool}.
        """
        return {k: getattr(self, k) for k in SECTION_KEYS}

    def table(self) -> dict[str, Any]:
        """The robot's `[[robots]]` table: `x_m` and `materials` when given, then every key of
        `SECTION_KEYS` (what a manifest records; `robot_specs` reads it back the same).

        Returns:
            The table as TOML and JSON write it (materials as a list).
        """
        out: dict[str, Any] = {}
        if self.x_m is not None:
            out["x_m"] = self.x_m
        if self.materials is not None:
            out["materials"] = list(self.materials)
        return out | self.section()


def check_count(value: object, where: str | None) -> int:
    """`value` as a robot count (`robots = N`), refused unless an int in 1..`MAX_ROBOTS`."""
    ok = is_integer(value) and 1 <= value <= MAX_ROBOTS
    check(ok, "robots", f"1..{MAX_ROBOTS}", value, where)
    assert isinstance(value, int)
    return value


def named(exc: InvalidInput, prefix: str, where: str | None) -> InvalidInput:
    """`exc` naming its field after `prefix` (`robots[1].`, `robot.`) instead of `robots.`."""
    field = exc.field.replace(_PREFIX, prefix, 1)
    return InvalidInput(field, exc.allowed, exc.got, exc.where or where)


def robot_specs(value: object, where: str | None = None) -> tuple[RobotSpec, ...]:
    """The robots of a config's `robots` key: a count (`robots = N`: N robots at the default
    spacing) or an array of `[[robots]]` tables, each table's keys and types checked; the
    line's rules are `check_robots`'. Returns the robots, upstream first."""
    if not isinstance(value, list | tuple):
        return (RobotSpec(),) * check_count(value, where)
    check(1 <= len(value) <= MAX_ROBOTS, "robots", _COUNT_OR_TABLES, value, where)
    specs = []
    for index, table in enumerate(value):
        allowed = "a table of " + ", ".join(ROBOT_KEYS)
        check(isinstance(table, dict), f"robots[{index}]", allowed, table, where)
        for key in table:
            allowed = "one of " + ", ".join(ROBOT_KEYS)
            check(key in ROBOT_KEYS, f"robots[{index}].{key}", allowed, None, where)
        try:
            specs.append(RobotSpec(**table))
        except InvalidInput as exc:
            raise named(exc, f"robots[{index}].", where) from None
    return tuple(specs)


def resized(specs: Sequence[RobotSpec], n: int) -> tuple[RobotSpec, ...]:
    """`n` robots at the default spacing sorting every material, keeping the pauses: robot k
    takes robot k's values of `SECTION_KEYS`, a robot past the last takes the last's (what
    `--robots N` and a sweep's `robots = N` do to robots given one by one)."""
    return tuple(RobotSpec(**specs[min(k, len(specs) - 1)].section()) for k in range(n))


def resized_tables(tables: Sequence[object], n: int) -> list[dict[str, Any]]:
    """`resized` on `[[robots]]` tables as parsed (a sweep's base under a variant's count):
    robot k keeps only table k's keys of `SECTION_KEYS` (the last table's past the last; a
    non-table entry gives no keys: it is refused where it is read, if it is kept)."""
    out = []
    for k in range(n):
        table = tables[min(k, len(tables) - 1)]
        kept = table.items() if isinstance(table, dict) else ()
        out.append({key: v for key, v in kept if key in SECTION_KEYS})
    return out


def check_robots(specs: Sequence[RobotSpec], materials: Materials, where: str | None) -> None:
    """Refuse robots (upstream first) that break the line's rules (module docstring) or name
    a material not of the catalogue's `materials`, naming the field and the file `where`."""
    for index, spec in enumerate(specs):
        ok = isinstance(spec, RobotSpec)
        check(ok, f"robots[{index}]", "a table of " + ", ".join(ROBOT_KEYS), spec, where)
    _check_positions(specs, where)
    for index, spec in enumerate(specs):
        unknown = set(spec.materials or ()) - set(materials.names)
        allowed = "the catalogue's materials: " + ", ".join(materials.names)
        check(not unknown, f"robots[{index}].materials", allowed, sorted(unknown), where)
    sorted_somewhere = {n for spec in specs for n in (spec.materials or materials.names)}
    left = [n for n in materials.names if n not in sorted_somewhere]
    if left:
        allowed = "every material sorted by at least one robot"
        raise InvalidInput("robots", allowed, f"none sorts {', '.join(left)}", where)


def _check_positions(specs: Sequence[RobotSpec], where: str | None) -> None:
    """The robots' `x_m`: all given or none; given, the line model's spacing rules."""
    given = [spec.x_m is not None for spec in specs]
    if not any(given):
        return
    if not all(given):
        index = given.index(False)
        allowed = "a number [m], given for every robot or for none"
        raise InvalidInput(f"robots[{index}].x_m", allowed, None, where)
    xs = [spec.x_m for spec in specs if spec.x_m is not None]  # all given (checked above)
    if xs[0] < 0.0:
        allowed = ">= 0 m (the first robot; the camera stays upstream of it)"
        raise InvalidInput("robots[0].x_m", allowed, xs[0], where)
    for index in range(1, len(xs)):
        if xs[index] - xs[index - 1] < MIN_SPACING_M - 1e-9:
            allowed = f">= {MIN_SPACING_M} m past robots[{index - 1}] (at {xs[index - 1]:g} m)"
            raise InvalidInput(f"robots[{index}].x_m", allowed, xs[index], where)
    if xs[-1] > MAX_LAST_X_M:
        allowed = f"<= {MAX_LAST_X_M:g} m (the longest belt ends 1.5 m past the last robot)"
        raise InvalidInput(f"robots[{len(xs) - 1}].x_m", allowed, xs[-1], where)
