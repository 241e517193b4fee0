"""The plant's numbers a config is checked against, kept where nothing heavy is imported: the
compiled model (`sim.model`) and the cell (`sim.cell`) import them from here.

`CellSettings` holds what changes the compiled cell (cup diameter, belt length and width);
`sim.model.scene_edits` applies it to `models/cell/scene.xml`.
"""

from __future__ import annotations

from dataclasses import dataclass

from sim.checks import is_finite_in
from sim.errors import InvalidInput
from sim.flow.limits import BELT_WIDTH_M, BELT_WIDTH_RANGE_M, BELT_X_RANGE

FRAME_SIZE = (640, 360)
"""The belt camera's frame size by default [px] (an episode config's `[camera]` may change it)."""
CAMERA_ASPECT = (16, 9)
"""Aspect ratio of the belt camera's calibration (`models/cell/belt_camera_calibration.json`,
1280 x 720): a resolution of another shape would need its own calibration."""
CAMERA_WIDTH_RANGE = (384, 1920)
"""Frame widths accepted [px]. The pipeline finds the belt from its 4 cm corner markers: at
320 x 180 they are 8 px across, no longer fill the check patch around their place, and every
frame is refused. On the short uniform flow of `tests/test_cell_settings.py` the codes agree
with the truth's 97.1 % at 352 x 198, 97.6 % at 384 x 216, 98.8 % at 640 x 360 and 99.2 % at
960 x 540 and 1920 x 1080. 1920 x 1080 is a stereo camera's largest video mode."""
VACUUM_RANGE_PA = (1e3, 101325.0)
"""Vacuum levels accepted [Pa]: 1 kPa (a blower) to a perfect vacuum (1 atm below)."""
CUP_DIAMETER_M = 0.06
"""The scene's cup: `cup_collision`'s radius 0.03 m (`tests/test_cell_settings.py` checks it)."""
LINE_CUP_DIAMETER_M = 0.05
"""A line's cup by default (two robots or more; `default_cup_diameter_m`): the 60 mm cup cannot
seal on the narrowest items of the varied world (crumpled paper scraps 29-31 mm wide), and a
line exists to pick every item (docs/line.md, "Every item")."""
CUP_DIAMETER_RANGE_M = (0.02, 0.12)
"""Cup diameters accepted [m]: 20 mm (the smallest bellows cups of a picker) to 120 mm (wider
than most items the catalogue holds: their outline must carry the lip)."""
BELT_LENGTH_M = 4.5
"""The scene's belt: `belt`'s half length 2.25 m, from x = -3.0 m to the discharge at +1.5 m."""
BELT_LENGTH_RANGE_M = (4.0, 20.0)
"""Belt lengths accepted [m]. At 4 m the discharge is at x = +1.0 m: an unpicked item is
discarded once its centre passes 0.77 m (the robot's reach ends at 0.62 m, `sim.episode.loop`)
and the largest item reaches 0.21 m beyond its centre, so none tips over the end before. 20 m:
a long sorting line."""
MAX_ROBOTS = 4
"""Most robots of a line."""
MIN_SPACING_M = 1.8
"""Least distance between neighbouring robots [m]: the scene's cage length (posts at +-0.9 m)."""
DISCHARGE_PAST_LAST_M = BELT_X_RANGE[1]
"""The belt runs this far past the last robot [m], as the scene's past its robot at x = 0."""
MAX_LAST_X_M = BELT_X_RANGE[0] + BELT_LENGTH_RANGE_M[1] - DISCHARGE_PAST_LAST_M
"""Farthest position of the last robot [m]: the longest belt accepted ends 1.5 m past it."""


def default_cup_diameter_m(robots: int) -> float:
    """The cup's diameter [m] when the config gives none: the single cell's 60 mm (its figures
    were measured with it) for one robot, `LINE_CUP_DIAMETER_M` for a line of two or more."""
    return LINE_CUP_DIAMETER_M if robots >= 2 else CUP_DIAMETER_M


@dataclass(frozen=True)
class CellSettings:
    """What changes the compiled cell; hashable, so compiled cells are cached by it.

    Attributes:
        cup_diameter_m: Diameter of the vacuum cup's lip [m].
        belt_length_m: Length of the belt, infeed (x = -3.0 m) to discharge [m].
        belt_width_m: Width of the belt [m] (`BELT_WIDTH_RANGE_M`).
    """

    cup_diameter_m: float = CUP_DIAMETER_M
    belt_length_m: float = BELT_LENGTH_M
    belt_width_m: float = BELT_WIDTH_M

    def __post_init__(self) -> None:
        lo, hi = CUP_DIAMETER_RANGE_M
        if not is_finite_in(self.cup_diameter_m, lo, hi):
            raise InvalidInput("cup.diameter_m", f"{lo}..{hi} m", self.cup_diameter_m)
        lo, hi = BELT_LENGTH_RANGE_M
        if not is_finite_in(self.belt_length_m, lo, hi):
            raise InvalidInput("belt.length_m", f"{lo}..{hi} m", self.belt_length_m)
        lo, hi = BELT_WIDTH_RANGE_M
        if not is_finite_in(self.belt_width_m, lo, hi):
            raise InvalidInput("belt.width_m", f"{lo}..{hi} m", self.belt_width_m)
        # 0.06 and 0.060000000001 compile alike: one cache key per model.
        object.__setattr__(self, "cup_diameter_m", float(self.cup_diameter_m))
        object.__setattr__(self, "belt_length_m", float(self.belt_length_m))
        object.__setattr__(self, "belt_width_m", float(self.belt_width_m))

    @property
    def is_default(self) -> bool:
        """Whether these are the scene file's own numbers."""
        return self == CellSettings()
