"""`RANGES`: every numeric key of a config file with its range, read from the schema's field
metadata (a section's keys dotted, a robot's as `robots[0].<key>`, the old `[robot]` section's
as `robot.<key>`). The tests walk both ends of each and just outside them."""

from __future__ import annotations

from sim.config import migration
from sim.config.episode import SECTIONS
from sim.config.fields import Range, settings_of
from sim.config.robots import RobotSpec
from sim.config.settings import EpisodeSettings


def _ranges(cls: type, prefix: str) -> dict[str, Range]:
    return {
        prefix + (spec.name or f.name): spec.range
        for f, spec in settings_of(cls)
        if spec.range is not None
    }


RANGES: dict[str, Range] = {
    **_ranges(EpisodeSettings, ""),
    **_ranges(RobotSpec, "robots[0]."),
    **migration.RANGES,
    **{k: v for name, cls in SECTIONS.items() for k, v in _ranges(cls, f"{name}.").items()},
}
"""Every numeric key with its range; `checked_by` names the module whose check enforces a key
checked elsewhere than `sim.config.fields.validate`."""
