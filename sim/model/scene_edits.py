"""The cell's physical settings that change its compiled model, applied to `models/cell/scene.xml`.

`CellSettings` (`sim.config.plant`) holds what a user may vary in the model itself: the vacuum
cup's diameter and the belt's length and width. The defaults are the scene file's own numbers,
and a cell with default settings is compiled from the file as it is (`compile_scene`), so its
model is the file's to the bit. Any other value is written into the file's `MjSpec` before it
is compiled, by pure functions `(spec, value) -> None` that find the elements by name:

- `set_cup_diameter`: the cup's lip (`cup_collision`, the geom that seals, `sim.cell.suction`)
  and its bellows (`cup_bellows`, drawn, keeping its overhang over the lip). The cup link's
  inertia is given explicitly in the robot's file, so the robot's dynamics do not change.
- `set_belt_length`: the belt (`belt`), its frame (`belt_frame`) and side rails (`rail_left`,
  `rail_right`) keep their upstream (infeed) end and end at the new discharge; the discharge
  legs move with it and a longer belt gets more legs (drawn only). The camera, its markers,
  the robot, the cage and the bins stay where they are.
- `sim.model.belt_width.set_belt_width`: the belt, its rails and legs, the camera's rig and
  markers, the cage and the bins (keeping their release points in the robot's reach) follow
  the belt's edges; applied once the bins are laid out (`compile_scene`).

Everything else that depends on these numbers reads them back from the compiled model: the
cup's radius, area and seal margin (`sim.cell.suction`), the clearance of a pick's path and the
riders it wakes (`sim.episode.pick_control`, `sim.episode.loop`), the belt's discharge end
(`sim.cell.conveyor.BeltGeometry`: items past it are missed, `ItemPool.park_missed`; its
half width, which the camera's stripes, the true perception and the planners' grid take), the
throw and bin checks, the bins' release points (`sim.cell.robots.RobotView.drop_xyz`). A cup
larger than the scene's reaches farther around the TCP by its extra radius
(`Cell.cup_extra_m`): riders wake that much earlier (`Cell.wake_x`) and unpicked items are
discarded that much later (`sim.episode.loop`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from sim.config.plant import CellSettings
from sim.paths import SCENE_XML

if TYPE_CHECKING:
    import mujoco

LEG_SPACING_M = 2.4
"""Longest gap between the belt's leg pairs (the scene's middle and discharge legs) [m]."""
_BELT_RUN = ("belt", "belt_frame", "rail_left", "rail_right")
_DISCHARGE_LEGS = ("belt_leg_discharge_left", "belt_leg_discharge_right")
_MIDDLE_LEGS = ("belt_leg_middle_left", "belt_leg_middle_right")


def set_cup_diameter(spec: mujoco.MjSpec, diameter_m: float, *, prefix: str = "") -> None:
    """The cup's lip (`cup_collision`) `diameter_m` [m] across; the bellows keep their overhang.
    `prefix` names the robot (one of a sorting line, `sim.model.line_model`)."""
    lip, bellows = spec.geom(f"{prefix}cup_collision"), spec.geom(f"{prefix}cup_bellows")
    overhang = float(bellows.size[0] - lip.size[0])
    lip.size[0] = 0.5 * diameter_m
    bellows.size[0] = 0.5 * diameter_m + overhang


def set_belt_length(spec: mujoco.MjSpec, length_m: float) -> None:
    """The belt `length_m` [m] long from its infeed end, which stays (see the module docstring)."""
    belt = spec.geom("belt")
    x_infeed = float(belt.pos[0] - belt.size[0])
    shift = (x_infeed + length_m) - float(belt.pos[0] + belt.size[0])
    for name in _BELT_RUN:
        geom = spec.geom(name)
        lo, hi = float(geom.pos[0] - geom.size[0]), float(geom.pos[0] + geom.size[0]) + shift
        geom.pos[0], geom.size[0] = 0.5 * (lo + hi), 0.5 * (hi - lo)
    for name in _DISCHARGE_LEGS:
        spec.geom(name).pos[0] += shift
    # Legs under a longer belt, evenly between the middle and the discharge pair (drawn only).
    start, end = (
        float(spec.geom(_MIDDLE_LEGS[0]).pos[0]),
        float(spec.geom(_DISCHARGE_LEGS[0]).pos[0]),
    )
    gaps = math.ceil((end - start) / LEG_SPACING_M - 1e-9)
    for k in range(1, gaps):
        x = start + k * (end - start) / gaps
        for middle in _MIDDLE_LEGS:
            template = spec.geom(middle)
            pos = template.pos.copy()
            pos[0] = x
            spec.worldbody.add_geom(
                template.classname,
                name=middle.replace("middle", f"extra_{k}"),
                type=template.type,
                size=template.size.copy(),
                pos=pos,
                material=template.material,
            )


def apply_settings(spec: mujoco.MjSpec, settings: CellSettings, materials=None) -> None:
    """Every setting of `settings` written into `spec`, whose bins are those of `materials`
    (the file's thesis bins when None)."""
    from perception.codes import THESIS_MATERIALS
    from sim.model.belt_width import set_belt_width

    set_cup_diameter(spec, settings.cup_diameter_m)
    set_belt_length(spec, settings.belt_length_m)
    set_belt_width(spec, settings.belt_width_m, materials or THESIS_MATERIALS)


def compile_scene(
    settings: CellSettings | None = None, path=SCENE_XML, materials=None
) -> mujoco.MjModel:
    """The cell of `path` compiled with `settings` and one bin per material of `materials`
    (`sim.model.bin_layout`; the file's thesis bins when None): the file as it is for the
    defaults, else its `MjSpec` edited (as `apply_settings`, the bins laid out before the belt's
    width moves them: `lay_out_bins`, `set_belt_width`) and compiled, checked as
    `sim.model.mjcf` checks a file.

    Raises:
        ModelFileError: the file is refused (`sim.model.mjcf.load_model`).
    """
    from perception.codes import THESIS_MATERIALS
    from sim.model.belt_width import set_belt_width
    from sim.model.bin_layout import lay_out_bins
    from sim.model.mjcf import CELL_ELEMENTS, cell_elements, compile_spec, load_scene, load_spec

    settings = settings or CellSettings()
    thesis_bins = materials is None or materials.is_thesis
    if settings.is_default and thesis_bins:
        return load_scene(path)
    spec = load_spec(path, CELL_ELEMENTS)
    set_cup_diameter(spec, settings.cup_diameter_m)
    set_belt_length(spec, settings.belt_length_m)
    if not thesis_bins:
        lay_out_bins(spec, materials)
    set_belt_width(spec, settings.belt_width_m, materials or THESIS_MATERIALS)
    return compile_spec(spec, path, cell_elements(materials))
