"""A config's keys declared once, as dataclass field metadata.

Each field of a config dataclass that a file may set carries a `Setting` (`setting(...)`): its
range or choices, its unit, its help and, for the top-level keys `sortsim run` takes, its
command-line option. One validator reads them (`validate`), one function refuses unknown keys
(`check_keys`), and every refusal is the project's one line (`InvalidInput` through
`sim.checks.check`: field, what is allowed, what was given, the file). The command line's
options (`sim.config.options`), a sweep's table and docs/settings.md read the same metadata.

Plain dataclasses rather than a validation library: the refusals keep their one-line texts
word for word, and no dependency is added. This module imports nothing heavy.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from sim.checks import check, is_integer, is_number

SETTING = "setting"
"""The key of a field's metadata holding its `Setting`."""


@dataclass(frozen=True)
class Range:
    """The documented range of one numeric key: what loading accepts (`allows`) and what its
    refusal says (`allowed`).

    Attributes:
        lo: Smallest value [the key's unit].
        hi: Largest value (excluded when `hi_open`).
        allowed: The refusal's words (`0.05..5 s`).
        integer: Only ints (not a float of integer value, not a bool).
        multiple: An int's step (a multiple of it).
        hi_open: `hi` itself is out of range: [lo, hi).
        slack: How far below `lo` and above `hi` a value is still taken, for the rounding of
            another unit (the belt's speed, checked in m/s) [the key's unit].
        entries: "": one number; "list": a list of them (probabilities summing to 1);
            "rows": a list of such lists; "table": a table of them by name (shares summing
            to 1).
        checked_by: The module whose check enforces it, when not `validate`.
    """

    lo: float
    hi: float
    allowed: str
    integer: bool = False
    multiple: int = 1
    hi_open: bool = False
    slack: tuple[float, float] = (0.0, 0.0)
    entries: str = ""
    checked_by: str = ""

    def allows(self, value: object) -> bool:
        """Whether `value` (as a file gives it) is a number of the right kind inside the ends."""
        if not is_number(value) or (self.integer and not is_integer(value)):
            return False
        # Ints compared as ints: 2**63 - 1 + 0.0 would round to 2**63.
        lo = self.lo - self.slack[0] if self.slack[0] else self.lo
        hi = self.hi + self.slack[1] if self.slack[1] else self.hi
        if not (lo <= value and (value < hi if self.hi_open else value <= hi)):
            return False
        return not self.integer or value % self.multiple == 0

    def check(self, key: str, value: object, where: str | None = None) -> None:
        """Refuse `value` of `key` (from file `where`) in one line unless it is inside."""
        check(self.allows(value), key, self.allowed, value, where)


@dataclass(frozen=True)
class Setting:
    """What a config key allows and how it is described.

    Attributes:
        range: Its numeric range (`Range`), if a number.
        choices: The names it may be, if a name.
        boolean: true | false.
        number: Only "a number" is checked by `validate` (its range is `range.checked_by`'s).
        to_float: Kept as a float once checked (an int given for m/s, items/m, ...).
        unit: Its unit, when neither its help nor its name's suffix says it.
        help: The command line's help of its option (`{lo}`, `{hi}`, `{allowed}` and
            `{default}` filled in from the range and the field).
        option: Its `sortsim run` option (`--duration`); "": none.
        keyword: `sim.config.load`'s keyword of the option, when not the field's name.
        metavar: The option's metavar.
        name: Its name in `RANGES` when not the field's (`<material>`).
    """

    range: Range | None = None
    choices: tuple[str, ...] | None = None
    boolean: bool = False
    number: bool = False
    to_float: bool = False
    unit: str = ""
    help: str = ""
    option: str = ""
    keyword: str = ""
    metavar: str | None = None
    name: str = ""

    @property
    def allowed(self) -> str:
        """What a refusal of the key says is allowed."""
        if self.range is not None:
            return self.range.allowed
        if self.choices is not None:
            return " | ".join(self.choices)
        return "true | false" if self.boolean else "a number" if self.number else ""


def setting(default: Any = None, *, factory: Any = None, **meta: Any) -> Any:
    """A dataclass field whose key is described by `Setting(**meta)`.

    Args:
        default: Its default (None: unset unless given).
        factory: A default factory instead (a section's table).
        **meta: `Setting`'s attributes.

    Returns:
        The `dataclasses.field`.
    """
    metadata = {SETTING: Setting(**meta)}
    if factory is not None:
        return dataclasses.field(default_factory=factory, metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def settings_of(cls: type) -> list[tuple[dataclasses.Field, Setting]]:
    """The fields of config dataclass `cls` that carry a `Setting`, in declaration order."""
    return [(f, f.metadata[SETTING]) for f in dataclasses.fields(cls) if SETTING in f.metadata]


def validate(obj: Any, prefix: str = "", where: str | None = None) -> None:
    """Refuse, in one line naming `prefix` + the field, the first field of `obj` its `Setting`
    does not allow; a field unset (None) where its default is None passes. `to_float` fields
    are kept as floats.

    Args:
        obj: A config dataclass (frozen: converted values are set through `object`).
        prefix: Its keys' prefix (`belt.`, `robots.`).
        where: The file it came from, if any.
    """
    for f, spec in settings_of(type(obj)):
        value = getattr(obj, f.name)
        if value is None and f.default is None:
            continue
        key = prefix + f.name
        if spec.choices is not None:
            check(value in spec.choices, key, spec.allowed, value, where)
        elif spec.boolean:
            check(isinstance(value, bool), key, spec.allowed, value, where)
        elif spec.range is not None and not spec.range.checked_by:
            spec.range.check(key, value, where)
        elif spec.number:
            check(is_number(value), key, "a number", value, where)
        if spec.to_float:
            object.__setattr__(obj, f.name, float(value))


def check_keys(cls: type, table: dict[str, Any], prefix: str, where: str | None) -> None:
    """Refuse a key of `table` that is no field of `cls`, naming `prefix` + the key.

    Args:
        cls: The config dataclass the table is read into.
        table: The table as parsed.
        prefix: Its keys' prefix (`belt.`).
        where: The file it came from, if any.
    """
    names = {f.name for f in dataclasses.fields(cls)}
    allowed = "one of " + ", ".join(sorted(names))
    for key in table:
        check(key in names, f"{prefix}{key}", allowed, None, where)
