"""Old layouts of a config file, read into today's before the schema sees them.

An old file (and an old manifest) gives every robot's pauses in one `[robot]` section::

    [robot]                     # every robot's defaults (a [[robots]] table's own key wins)
    pick_pause_s = 0.0          # extra dwell after each pick / place, 0..2 s
    place_pause_s = 0.0
    idle_sleep = true

`migrated` checks the section (naming `robot.<key>`) and writes its keys into each robot's
`[[robots]]` table (`robots = N`: N tables), so those files repeat their runs byte for byte.

An old file may also name the planner `oracle`, the name `seen_best` had before it was renamed
(it is no bound in physics, `planner.decision.managers.seen_best`): it is read as `seen_best`,
so the run repeats (its episodes.csv then names `seen_best`). The command line and the registry
know only the new name.
"""

from __future__ import annotations

from typing import Any

from sim.checks import check, is_integer
from sim.config.fields import Range, settings_of
from sim.config.plant import MAX_ROBOTS
from sim.config.robots import SECTION_KEYS, RobotSpec, named
from sim.errors import InvalidInput

SECTION = "robot"
"""The old section's key."""
RENAMED_PLANNERS = {"oracle": "seen_best"}
"""Old planner names -> today's, for files written before the rename."""
RANGES: dict[str, Range] = {
    f"{SECTION}.{f.name}": spec.range
    for f, spec in settings_of(RobotSpec)
    if f.name in SECTION_KEYS and spec.range is not None
}
"""The numeric keys of the old section, with their ranges (`RobotSpec`'s)."""


def migrated(data: dict[str, Any], where: str | None) -> dict[str, Any]:
    """`data` in today's layout: its `[robot]` section's keys written into every robot's table.

    Args:
        data: A config's settings as parsed (not changed).
        where: The file they came from, named by a refusal.

    Returns:
        `data` itself when it has no `[robot]` section and no renamed planner, else a new
        dict in today's layout.

    Raises:
        InvalidInput: One line naming `robot` or `robot.<key>` when the section is not a table
            of `RobotSpec`'s pauses and `idle_sleep` within their ranges.
    """
    if data.get("planner") in RENAMED_PLANNERS:
        data = {**data, "planner": RENAMED_PLANNERS[data["planner"]]}
    if SECTION not in data:
        return data
    section = _checked_section(data[SECTION], where)
    out = {k: v for k, v in data.items() if k != SECTION}
    robots = out.get("robots", 1)
    if isinstance(robots, list | tuple) and 1 <= len(robots) <= MAX_ROBOTS:
        out["robots"] = [section | t if isinstance(t, dict) else t for t in robots]
    elif is_integer(robots) and 1 <= robots <= MAX_ROBOTS:
        out["robots"] = [dict(section) for _ in range(robots)]
    return out


def _checked_section(value: object, where: str | None) -> dict[str, Any]:
    """The section's keys and values, each checked as a robot's, naming `robot.<key>`."""
    check(isinstance(value, dict), SECTION, f"a table [{SECTION}]", value, where)
    assert isinstance(value, dict)
    allowed = "one of " + ", ".join(sorted(SECTION_KEYS))
    for key in value:
        check(key in SECTION_KEYS, f"{SECTION}.{key}", allowed, None, where)
    try:
        RobotSpec(**value)
    except InvalidInput as exc:
        raise named(exc, f"{SECTION}.", where) from None
    return dict(value)
