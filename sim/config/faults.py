"""A shift's faults: what fails, when, for how long, as one validated schedule.

A fault is a window of simulated time [start_s, start_s + duration_s) during which one part of
the cell behaves otherwise (the kinds below). A config lists faults by hand (`[[faults]]`) or
draws them (`[faults_random]`: per kind, the mean time between faults and the mean time to
repair, exponential, seeded); both end up in one `FaultSchedule`, which the episode reads and
nothing writes. Two faults of one kind on one part (the same robot, the same camera, or the
belt) may not overlap: a part is failed or not. Faults of different kinds may (a camera out
while a robot is stopped).

Kinds and their keys:
    camera_outage: `camera` (0 = the scene's, upstream first; None: every camera): no frames.
    robot_stop: `robot` (0 = the most upstream): a protective stop; the robot holds where it is.
    belt_stop: the belt and the infeed stop together.
    vacuum_drop: `vacuum_pa`: the supply's vacuum falls to this level [Pa].
    belt_speed: `speed_factor`: the belt runs at this factor of its speed.
Nothing heavy is imported.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sim.checks import check, is_finite_number, is_integer, is_number
from sim.config.fields import check_keys

FAULT_KINDS = ("camera_outage", "robot_stop", "belt_stop", "vacuum_drop", "belt_speed")
"""Every kind of fault, in the order the outputs list them."""
KIND_KEYS = {
    "camera_outage": ("camera",),
    "robot_stop": ("robot",),
    "belt_stop": (),
    "vacuum_drop": ("vacuum_pa",),
    "belt_speed": ("speed_factor",),
}
"""The keys of each kind besides `kind`, `start_s` and `duration_s`."""
SPEED_FACTOR_RANGE = (0.1, 2.0)
"""A `belt_speed` fault's factor: the belt's drive at this share of its set speed."""
RANDOM_KEYS = {
    kind: tuple(k for k in keys if k not in ("robot", "camera")) for kind, keys in KIND_KEYS.items()
}
"""The keys of each kind's `[faults_random.<kind>]` table besides `mtbf_s` and `mttr_s`."""
FAULT_STREAM = 48
"""The random faults' own stream of the episode's seed (the flow's draws stay as they are)."""


def _check_kind_value(
    kind: str, field: str, speed_factor: float | None, vacuum_pa: float | None
) -> None:
    """Refuse in one line a `belt_speed` fault's factor outside `SPEED_FACTOR_RANGE` or a
    `vacuum_drop`'s vacuum that is not a positive number [Pa] (`field`: the key's prefix)."""
    if kind == "belt_speed":
        lo, hi = SPEED_FACTOR_RANGE
        ok = is_finite_number(speed_factor) and lo <= speed_factor <= hi
        check(ok, f"{field}.speed_factor", f"{lo:g}..{hi:g}", speed_factor)
    if kind == "vacuum_drop":
        ok = is_finite_number(vacuum_pa) and vacuum_pa > 0
        check(ok, f"{field}.vacuum_pa", "a vacuum > 0 Pa", vacuum_pa)


@dataclass(frozen=True)
class Fault:
    """One fault: `kind` over [start_s, start_s + duration_s) [s], on the part its keys name.

    Attributes:
        kind: One of `FAULT_KINDS`.
        start_s: When it starts [s of simulated time], >= 0.
        duration_s: How long it lasts [s], > 0.
        robot: robot_stop: the robot's index, 0 the most upstream.
        camera: camera_outage: the camera's index (0 the scene's, upstream first); None: all.
        vacuum_pa: vacuum_drop: the supply's vacuum during it [Pa] (in an episode's config:
            1000 Pa up to the cup's `vacuum_pa`, a drop).
        speed_factor: belt_speed: the belt's speed during it, as a factor of its set speed.
    """

    kind: str
    start_s: float
    duration_s: float
    robot: int | None = None
    camera: int | None = None
    vacuum_pa: float | None = None
    speed_factor: float | None = None

    def __post_init__(self) -> None:
        check(self.kind in FAULT_KINDS, "faults.kind", " | ".join(FAULT_KINDS), self.kind)
        field = f"faults.{self.kind}"
        ok = is_finite_number(self.start_s) and self.start_s >= 0
        check(ok, f"{field}.start_s", "a time >= 0 s", self.start_s)
        ok = is_finite_number(self.duration_s) and self.duration_s > 0
        check(ok, f"{field}.duration_s", "a duration > 0 s", self.duration_s)
        own = KIND_KEYS[self.kind]
        for key in ("robot", "camera", "vacuum_pa", "speed_factor"):
            value = getattr(self, key)
            if key not in own:
                check(value is None, f"{field}.{key}", f"only the keys {self._keys()}", value)
        if self.kind == "robot_stop":
            ok = self.robot is not None and is_integer(self.robot) and self.robot >= 0
            check(ok, f"{field}.robot", "a robot's index, 0 the most upstream", self.robot)
        if self.kind == "camera_outage" and self.camera is not None:
            ok = is_integer(self.camera) and self.camera >= 0
            check(ok, f"{field}.camera", "a camera's index, 0 upstream; left out: all", self.camera)
        _check_kind_value(self.kind, field, self.speed_factor, self.vacuum_pa)

    def _keys(self) -> str:
        return ", ".join(("kind", "start_s", "duration_s", *KIND_KEYS[self.kind]))

    @property
    def end_s(self) -> float:
        """When it ends [s]: the part works again from this time on."""
        return self.start_s + self.duration_s

    @property
    def part(self) -> tuple[str, int | None]:
        """The part it fails: ("robot", k), ("camera", k or None: all), or (kind, None)."""
        if self.kind == "robot_stop":
            return ("robot", self.robot)
        if self.kind == "camera_outage":
            return ("camera", self.camera)
        return (self.kind, None)

    def active(self, t: float) -> bool:
        """Whether the fault holds at time `t` [s]."""
        return self.start_s <= t < self.end_s

    def label(self) -> str:
        """A short name for tables, the timeline and the video: `robot_stop 1`, `belt_stop`."""
        target = self.part[1]
        return self.kind if target is None else f"{self.kind} {target}"


@dataclass(frozen=True)
class FaultSchedule:
    """Every fault of an episode, by start time; empty: nothing fails (today's episode).

    Attributes:
        faults: The faults, sorted by start time.
    """

    faults: tuple[Fault, ...] = ()

    def __post_init__(self) -> None:
        ordered = tuple(sorted(self.faults, key=lambda f: (f.start_s, FAULT_KINDS.index(f.kind))))
        object.__setattr__(self, "faults", ordered)
        for a, b in _same_part_pairs(ordered):
            if b.start_s < a.end_s:
                allowed = "faults of one kind on one part that do not overlap"
                got = f"{a.label()} at {a.start_s:g}-{a.end_s:g} s and {b.start_s:g}-{b.end_s:g} s"
                check(False, "faults", allowed, got)

    def __bool__(self) -> bool:
        return bool(self.faults)

    def active(self, t: float) -> tuple[Fault, ...]:
        """The faults holding at time `t` [s]."""
        return tuple(f for f in self.faults if f.active(t))

    def of_kind(self, kind: str) -> tuple[Fault, ...]:
        """The faults of one kind."""
        return tuple(f for f in self.faults if f.kind == kind)

    def boundaries(self) -> tuple[float, ...]:
        """Every time a fault starts or ends [s], sorted, each once: the episode acts on them."""
        return tuple(sorted({t for f in self.faults for t in (f.start_s, f.end_s)}))

    def downtime_s(self, kind: str, until_s: float) -> float:
        """Seconds of faults of `kind` before `until_s` [s] (overlaps of different parts, as two
        robots stopped at once, count each)."""
        return sum(max(0.0, min(f.end_s, until_s) - f.start_s) for f in self.of_kind(kind))

    def check_cell(self, robots: int, cameras: int, end_s: float | None) -> None:
        """Refuse in one line a fault naming a robot or camera the cell lacks, or starting at or
        after the episode's end `end_s` [s] (None: no end known yet)."""
        for f in self.faults:
            if f.kind == "robot_stop" and f.robot is not None and f.robot >= robots:
                check(
                    False,
                    "faults.robot_stop.robot",
                    f"0..{robots - 1} (the line's robots)",
                    f.robot,
                )
            if f.kind == "camera_outage" and f.camera is not None and f.camera >= cameras:
                allowed = f"0..{cameras - 1} (the cell's cameras), or left out: all"
                check(False, "faults.camera_outage.camera", allowed, f.camera)
            if end_s is not None and f.start_s >= end_s:
                allowed = f"a start before the episode's end ({end_s:g} s)"
                check(False, f"faults.{f.kind}.start_s", allowed, f.start_s)


def _same_part_pairs(faults: tuple[Fault, ...]):
    """(earlier, later) pairs of consecutive faults of one kind on one part (`camera_outage`
    of every camera overlaps each single camera's)."""
    by_part: dict[tuple, list[Fault]] = {}
    for f in faults:
        by_part.setdefault((f.kind, f.part[1]), []).append(f)
    for (kind, target), group in by_part.items():
        yield from zip(group, group[1:], strict=False)
        if kind == "camera_outage" and target is not None:
            for every in by_part.get((kind, None), []):
                for one in group:
                    first, second = sorted((every, one), key=lambda f: f.start_s)
                    yield first, second


@dataclass(frozen=True)
class RandomFaults:
    """Faults of one kind drawn over an episode: up-times exponential with mean `mtbf_s`,
    repairs exponential with mean `mttr_s`, one part after another.

    Attributes:
        kind: One of `FAULT_KINDS`.
        mtbf_s: Mean time between faults [s] (from a repair to the next fault), > 0.
        mttr_s: Mean time to repair [s], > 0.
        vacuum_pa: vacuum_drop: the vacuum during each [Pa] (as `Fault`'s).
        speed_factor: belt_speed: the factor during each.
    """

    kind: str
    mtbf_s: float
    mttr_s: float
    vacuum_pa: float | None = None
    speed_factor: float | None = None

    def __post_init__(self) -> None:
        check(self.kind in FAULT_KINDS, "faults_random", " | ".join(FAULT_KINDS), self.kind)
        field = f"faults_random.{self.kind}"
        for key in ("mtbf_s", "mttr_s"):
            value = getattr(self, key)
            ok = is_finite_number(value) and value > 0
            check(ok, f"{field}.{key}", "a time > 0 s", value)
        own = RANDOM_KEYS[self.kind]
        for key in ("vacuum_pa", "speed_factor"):
            if key not in own:
                allowed = "only the keys " + ", ".join(("mtbf_s", "mttr_s", *own))
                check(getattr(self, key) is None, f"{field}.{key}", allowed, getattr(self, key))
        _check_kind_value(self.kind, field, self.speed_factor, self.vacuum_pa)

    def draw(self, rng: np.random.Generator, parts: tuple, end_s: float) -> list[Fault]:
        """This kind's faults on each of `parts` (robot or camera indices; (None,) for the belt
        or every camera) until `end_s` [s], from `rng`."""
        out = []
        for part in parts:
            t = float(rng.exponential(self.mtbf_s))
            while t < end_s:
                length = max(float(rng.exponential(self.mttr_s)), 1e-3)
                out.append(self._fault(t, min(length, end_s - t), part))
                t += length + float(rng.exponential(self.mtbf_s))
        return out

    def _fault(self, start_s: float, duration_s: float, part: int | None) -> Fault:
        keys: dict = {"robot": part} if self.kind == "robot_stop" else {}
        if self.kind == "camera_outage":
            keys = {"camera": part}
        if self.kind == "vacuum_drop":
            keys = {"vacuum_pa": self.vacuum_pa}
        if self.kind == "belt_speed":
            keys = {"speed_factor": self.speed_factor}
        return Fault(self.kind, round(start_s, 3), round(duration_s, 3), **keys)


def draw_schedule(
    given: tuple[Fault, ...],
    random: tuple[RandomFaults, ...],
    seed: int,
    robots: int,
    cameras: int,
    end_s: float,
) -> FaultSchedule:
    """The episode's schedule: the `given` faults and those drawn by `random` over [0, end_s)
    [s] from the episode's `seed` (its own stream: the flow is unchanged), robots' and cameras'
    faults per robot and per camera. A drawn fault that would overlap a given one of its part is
    left out (the given one stands)."""
    if not random:
        return FaultSchedule(given)
    rng = np.random.default_rng([int(seed), FAULT_STREAM])
    drawn: list[Fault] = []
    for spec in random:
        parts: tuple = (None,)
        if spec.kind == "robot_stop":
            parts = tuple(range(robots))
        elif spec.kind == "camera_outage":
            parts = tuple(range(cameras))
        drawn += spec.draw(rng, parts, end_s)
    kept = [d for d in drawn if not any(_clash(d, g) for g in given)]
    return FaultSchedule((*given, *kept))


def _clash(a: Fault, b: Fault) -> bool:
    same = a.kind == b.kind and (
        a.part == b.part or (a.kind == "camera_outage" and None in (a.part[1], b.part[1]))
    )
    return same and a.start_s < b.end_s and b.start_s < a.end_s


def availability(schedule: FaultSchedule, robots: int, end_s: float) -> float:
    """Share of robot-time [0, 1] over [0, end_s) that no robot_stop or belt_stop took: each
    robot's own stops and the belt's (a stopped belt feeds no robot), their union per robot."""
    if end_s <= 0 or robots <= 0:
        return 1.0
    belt = [(f.start_s, min(f.end_s, end_s)) for f in schedule.of_kind("belt_stop")]
    lost = 0.0
    for k in range(robots):
        own = [
            (f.start_s, min(f.end_s, end_s)) for f in schedule.of_kind("robot_stop") if f.robot == k
        ]
        lost += _union_length([w for w in (*belt, *own) if w[0] < end_s])
    return max(0.0, 1.0 - lost / (robots * end_s)) if math.isfinite(end_s) else 1.0


def _union_length(windows: list[tuple[float, float]]) -> float:
    total, reach = 0.0, -math.inf
    for lo, hi in sorted(windows):
        if hi <= reach:
            continue
        total += hi - max(lo, reach)
        reach = hi
    return total


def faults_of_tables(tables: Any, where: str | None = None) -> tuple[Fault, ...]:
    """The faults of a config's `[[faults]]` array of tables, each refused in one line naming
    its key (an unknown or missing one too) and `where`, the file."""
    keys = "kind, start_s, duration_s and the kind's keys"
    check(isinstance(tables, list | tuple), "faults", f"[[faults]] tables ({keys})", tables, where)
    out = []
    for i, table in enumerate(tables):
        if isinstance(table, Fault):
            out.append(table)
            continue
        check(isinstance(table, dict), f"faults[{i}]", f"a table ({keys})", table, where)
        check_keys(Fault, table, f"faults[{i}].", where)
        for key in ("kind", "start_s", "duration_s"):
            check(key in table, f"faults[{i}].{key}", "a value: required", None, where)
        out.append(Fault(**_floats(table, ("start_s", "duration_s", "vacuum_pa", "speed_factor"))))
    return tuple(out)


def random_faults_of_table(table: Any, where: str | None = None) -> tuple[RandomFaults, ...]:
    """The random faults of a config's `[faults_random]` table (one table per kind, keys
    `mtbf_s`, `mttr_s` and the kind's own), in `FAULT_KINDS`' order, refused in one line."""
    if isinstance(table, list | tuple) and all(isinstance(r, RandomFaults) for r in table):
        return tuple(sorted(table, key=lambda r: FAULT_KINDS.index(r.kind)))
    allowed = "a table of kinds (" + " | ".join(FAULT_KINDS) + "), each a table"
    check(isinstance(table, dict), "faults_random", allowed, table, where)
    out = []
    for kind, keys in table.items():
        check(kind in FAULT_KINDS, f"faults_random.{kind}", allowed, None, where)
        field = f"faults_random.{kind}"
        own = ", ".join(("mtbf_s", "mttr_s", *RANDOM_KEYS[kind]))
        check(isinstance(keys, dict), field, f"a table of {own}", keys, where)
        for key in keys:
            check(
                key in ("mtbf_s", "mttr_s", *RANDOM_KEYS[kind]),
                f"{field}.{key}",
                f"one of {own}",
                None,
                where,
            )
        for key in ("mtbf_s", "mttr_s"):
            check(key in keys, f"{field}.{key}", "a time > 0 s: required", None, where)
        out.append(RandomFaults(kind, **_floats(keys, ("mtbf_s", "mttr_s", *RANDOM_KEYS[kind]))))
    return tuple(sorted(out, key=lambda r: FAULT_KINDS.index(r.kind)))


def fault_tables(faults: tuple[Fault, ...]) -> list[dict]:
    """`[[faults]]` as a config file writes them: each fault's keys that are set."""
    return [{k: v for k, v in dataclasses.asdict(f).items() if v is not None} for f in faults]


def random_faults_table(random: tuple[RandomFaults, ...]) -> dict[str, dict]:
    """`[faults_random]` as a config file writes it: {kind: its keys that are set}."""
    return {
        r.kind: {k: v for k, v in dataclasses.asdict(r).items() if v is not None and k != "kind"}
        for r in random
    }


def _floats(table: dict, keys: tuple[str, ...]) -> dict:
    """`table` with the numbers of `keys` as floats (a TOML int for a time); others as given."""
    return {k: float(v) if k in keys and is_number(v) else v for k, v in table.items()}
