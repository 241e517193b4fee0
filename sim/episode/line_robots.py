"""A line's table of robots: where each robot stands and which materials it sorts.

An episode config's `robots` is either a count (1..4 robots at the default spacing, each
sorting every material) or an array of 1..4 tables, one per robot, upstream first::

    [[robots]]
    x_m = 0.0                           # its base centre along the belt [m]
    materials = ["aluminium", "plastic"]  # what it picks; omitted: every material
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

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from perception.codes import Materials
from sim.errors import InvalidInput

ROBOT_KEYS = ("x_m", "materials")
"""The keys of one robot's table."""
_PREFIX = "robots."


def _finite_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class LineRobotSpec:
    """One robot of a line as the config gives it.

    Attributes:
        x_m: x of its base centre along the belt [m]; None: the line's default spacing.
        materials: Names of the materials it sorts, as given (a non-empty tuple, no name
            twice); None: every material of the catalogue.
    """

    x_m: float | None = None
    materials: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        x = self.x_m
        if x is not None and not _finite_number(x):
            raise InvalidInput(f"{_PREFIX}x_m", "a number [m]", x)
        if x is not None:
            object.__setattr__(self, "x_m", float(x))
        names = self.materials
        if names is None:
            return
        allowed = "a non-empty list of material names, each once"
        if not isinstance(names, list | tuple) or not names:
            raise InvalidInput(f"{_PREFIX}materials", allowed, names)
        if not all(isinstance(n, str) for n in names) or len(set(names)) != len(names):
            raise InvalidInput(f"{_PREFIX}materials", allowed, list(names))
        object.__setattr__(self, "materials", tuple(names))

    def table(self) -> dict[str, Any]:
        """The robot's TOML table: only the keys given."""
        out: dict[str, Any] = {}
        if self.x_m is not None:
            out["x_m"] = self.x_m
        if self.materials is not None:
            out["materials"] = list(self.materials)
        return out


def _named(exc: InvalidInput, index: int, where: str | None) -> InvalidInput:
    """`exc` naming robot `index`'s field (`robots[index].x_m`)."""
    field = exc.field.replace(_PREFIX, f"robots[{index}].", 1)
    return InvalidInput(field, exc.allowed, exc.got, exc.where or where)


def robots_table(value: object, max_robots: int, where: str | None) -> tuple[LineRobotSpec, ...]:
    """The robots of a TOML array of tables `robots` (upstream first), each table's keys and
    types checked; the line's rules are `check_robots_table`'s."""
    allowed = f"1..{max_robots} robots, or an array of 1..{max_robots} [[robots]] tables"
    if not isinstance(value, list | tuple) or not 1 <= len(value) <= max_robots:
        raise InvalidInput("robots", allowed, value, where)
    specs = []
    for index, table in enumerate(value):
        if not isinstance(table, dict):
            raise InvalidInput(f"robots[{index}]", "a table of x_m, materials", table, where)
        for key in table:
            if key not in ROBOT_KEYS:
                allowed = "one of " + ", ".join(ROBOT_KEYS)
                raise InvalidInput(f"robots[{index}].{key}", allowed, None, where)
        try:
            specs.append(LineRobotSpec(**table))
        except InvalidInput as exc:
            raise _named(exc, index, where) from None
    return tuple(specs)


def check_robots_table(
    specs: Sequence[LineRobotSpec], materials: Materials, where: str | None
) -> None:
    """Refuse a table that breaks the line's rules (module docstring), naming the field; an
    empty table (`robots = N`) has none to break."""
    if not specs:
        return
    for index, spec in enumerate(specs):
        if not isinstance(spec, LineRobotSpec):
            raise InvalidInput(f"robots[{index}]", "a table of x_m, materials", spec, where)
    _check_positions(specs, where)
    for index, spec in enumerate(specs):
        unknown = set(spec.materials or ()) - set(materials.names)
        if unknown:
            allowed = "the catalogue's materials: " + ", ".join(materials.names)
            raise InvalidInput(f"robots[{index}].materials", allowed, sorted(unknown), where)
    sorted_somewhere = {n for spec in specs for n in (spec.materials or materials.names)}
    left = [n for n in materials.names if n not in sorted_somewhere]
    if left:
        allowed = "every material sorted by at least one robot"
        raise InvalidInput("robots", allowed, f"none sorts {', '.join(left)}", where)


def _check_positions(specs: Sequence[LineRobotSpec], where: str | None) -> None:
    """The robots' `x_m`: all given or none; given, the line model's spacing rules."""
    from sim.model.line_model import MAX_LAST_X_M, MIN_SPACING_M

    given = [spec.x_m is not None for spec in specs]
    if not any(given):
        return
    if not all(given):
        index = given.index(False)
        allowed = "a number [m], given for every robot or for none"
        raise InvalidInput(f"robots[{index}].x_m", allowed, None, where)
    xs = [spec.x_m for spec in specs]
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
