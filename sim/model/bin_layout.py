"""One bin per material: the cell's bins laid out for a catalogue's materials (MjSpec edits).

`models/cell/scene.xml` holds the thesis's three bins (`bin_paper` alone on the -y side of the
belt, wide enough for an A4 sheet; `bin_plastic` and `bin_aluminium` side by side on +y). A
catalogue with other materials gets its bins from `lay_out_bins`: the file's three are removed
and one bin per material is added, alternating sides (the first material on -y, the second on
+y, ...), up to four per side, centred under the robot and spaced along the belt. Each bin has
the elements the code looks up by name: the body `bin_<material>`, the geoms
`bin_<material>_floor_plate` and `bin_<material>_wall_*`, the release point (site)
`bin_<material>_drop` and the site `bin_<material>_floor`. Every release point of up to eight
bins lies inside the robot's reach (`tests/test_materials.py`).
"""

from __future__ import annotations

import mujoco

from perception.codes import THESIS_MATERIALS, Materials
from sim.errors import InvalidInput

SIDE_Y_M = 0.59
"""Distance of a bin's centre from the belt's centre line [m] (the paper bin's)."""
HALF_WIDTH_M = 0.14
"""Half the bin's size across the belt [m]: inner wall 0.45 m from the centre line."""
DEPTH_HALF_M = 0.15
"""Half the height of a bin's walls [m]."""
BODY_Z_M = -0.2
"""Height of a bin body's origin: rims 5 cm below the belt [m]."""
MAX_PER_SIDE = 4
PITCH_M = {1: 0.42, 2: 0.42, 3: 0.28, 4: 0.21}
"""Spacing of the bins' centres along the belt by the number on one side [m]."""
WALL_M = 0.005
"""Half the wall thickness [m]."""
DROP_INSET_M = 0.08
"""The release point lies this far from the bin's centre towards the belt [m]: 0.51 m from
the centre line, as the thesis bins' plastic and aluminium ones (the corner bins of four on a side
are out of reach farther out)."""
DROP_HEIGHT_M = 0.26
"""Release point above the bin body's origin [m] (6 cm above the belt)."""


def bin_centres(count: int) -> list[tuple[float, float]]:
    """(x, y) of the bins' centres [m] for `count` materials, in material order."""
    if not 1 <= count <= 2 * MAX_PER_SIDE:
        raise InvalidInput("bins", f"1..{2 * MAX_PER_SIDE}", count)
    sides = ([k for k in range(count) if k % 2 == 0], [k for k in range(count) if k % 2 == 1])
    out: dict[int, tuple[float, float]] = {}
    for sign, members in zip((-1.0, 1.0), sides, strict=True):
        pitch = PITCH_M.get(len(members), 0.0)
        for i, k in enumerate(members):
            out[k] = ((i - (len(members) - 1) / 2) * pitch, sign * SIDE_Y_M)
    return [out[k] for k in range(count)]


def _half_length(count: int) -> float:
    """Half a bin's length along the belt [m] when `count` bins share its side."""
    per_side = (count + 1) // 2
    return PITCH_M[per_side] / 2 - 0.025 if per_side > 1 else 0.2


def _box(body, name: str, size, pos, default) -> None:
    body.add_geom(
        name=name, default=default, type=mujoco.mjtGeom.mjGEOM_BOX, size=list(size), pos=list(pos)
    )


def lay_out_bins(spec: mujoco.MjSpec, materials: Materials) -> None:
    """Replace the scene's thesis bins with one bin per material of `materials` (in place).

    Leaves the spec untouched for the thesis's own materials (paper, plastic, aluminium).
    """
    if materials.names == THESIS_MATERIALS.names:
        return
    for name in THESIS_MATERIALS.names:
        spec.delete(spec.body(f"bin_{name}"))
    wall = spec.find_default("bin_wall")
    frame = spec.find_default("frame")
    hx = _half_length(materials.count)
    hy, hz, w = HALF_WIDTH_M, DEPTH_HALF_M, WALL_M
    for name, (x, y) in zip(materials.names, bin_centres(materials.count), strict=True):
        body = spec.worldbody.add_body(name=f"bin_{name}", pos=[x, y, BODY_Z_M])
        body.childclass = "cell"
        inward = -1.0 if y > 0 else 1.0  # towards the belt
        _box(body, f"bin_{name}_floor_plate", (hx, hy, w), (0, 0, -hz + w), wall)
        _box(body, f"bin_{name}_wall_inner", (hx, w, hz), (0, inward * (hy + w), 0), wall)
        _box(body, f"bin_{name}_wall_outer", (hx, w, hz), (0, -inward * (hy + w), 0), wall)
        _box(body, f"bin_{name}_wall_upstream", (w, hy + 2 * w, hz), (-hx - w, 0, 0), wall)
        _box(body, f"bin_{name}_wall_downstream", (w, hy + 2 * w, hz), (hx + w, 0, 0), wall)
        _box(body, f"bin_{name}_stand", (0.75 * hx, 0.06, 0.275), (0, 0, -0.425), frame)
        body.add_site(
            name=f"bin_{name}_drop", pos=[0, inward * DROP_INSET_M, DROP_HEIGHT_M], size=[0.01] * 3
        )
        body.add_site(
            name=f"bin_{name}_floor",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[0, 0, -0.12],
            size=[hx, hy, 0.03],
        )


def bin_elements(materials: Materials, prefix: str = ""):
    """The named elements of the bins the code looks up (for `sim.model.mjcf.require_elements`),
    of the robot whose bins' names start with `prefix` (a sorting line, `sim.model.line_model`)."""
    out = []
    for name in materials.names:
        out.append((("geom",), f"{prefix}bin_{name}_floor_plate"))
        out.append((("site",), f"{prefix}bin_{name}_drop"))
    return tuple(out)
