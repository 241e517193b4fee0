"""Writes `models/cell/items.xml`: the fixed pool of item bodies, generated from the catalogue.

`python -m sim.model.item_pool_xml` rewrites the file; a test checks that the committed file
matches.

Layout. `POOL_SIZE` slots (the flow generator's `POOL_CAPACITY_REQUIRED`, the most items the belt
carries at once at the densest setting), each a free body `item_<n>` (joint `item_<n>_joint`)
holding one geom per shape-and-pose family (`sim.flow.catalogue.FAMILIES`): `item_<n>_box`,
`item_<n>_cylinder_standing`, `item_<n>_cylinder_lying`, `item_<n>_capsule_lying`, all centred on
the body origin in the catalogue's body frame (z up, long axis along x), plus a visual-only
`item_<n>_label` (a cylinder sleeve: a can's or bottle's printed label). Only the geom of the
family a slot currently plays collides and is drawn; the others have contype = conaffinity = 0,
alpha 0 and group 5 (hidden), so one slot can become any item, of any size, at run time without
recompiling the model (`sim.cell.item_pool` writes the item's size, friction, colour, bounding
volumes, mass and inertia). The sizes and frictions written here are placeholders: those of the
largest catalogue type of each family.

Parked slots sit 2 m below the belt in a grid, with every geom non-colliding and gravity
compensated (`gravcomp` 1), so they float still, touch nothing and fall asleep (sleeping is
enabled here); a spawned slot gets gravity back. Item geoms have `priority` 1 so that their own
friction from the catalogue, not the belt's, acts in their contacts; lying round items use
condim 6 (rolling friction keeps bottles and cans from rolling on the moving belt).

Each slot also has a weld `item_<n>_grip` from `cup_link` (the robot's vacuum cup), inactive
until `sim.cell.suction` seals the cup on that item.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

from sim.flow.catalogue import FAMILIES, LYING_QUAT, Catalogue, load_catalogue
from sim.flow.generator import POOL_CAPACITY_REQUIRED
from sim.paths import MODELS_DIR

ITEMS_XML = MODELS_DIR / "cell" / "items.xml"
POOL_SIZE = POOL_CAPACITY_REQUIRED
"""Number of item bodies in the pool."""
PARK_Z = -2.0
"""Height of the parking grid, well below the floor [m]."""
PARK_PITCH = 0.4
"""Spacing of parked slots [m]."""
PARK_COLUMNS = 12
PARK_ORIGIN = (-2.4, -2.0)
"""(x, y) of the first parked slot [m]."""
HIDDEN_GROUP = 5
LABEL = "label"
ITEM_GROUP = 0
CUP_BODY = "cup_link"
GRIP_SOLREF = "0.004 1"
"""Weld stiffness of a sealed cup: time constant two time steps, critically damped."""


def park_position(slot: int) -> tuple[float, float, float]:
    """Where slot `slot` is parked [m]."""
    row, col = divmod(slot, PARK_COLUMNS)
    return (PARK_ORIGIN[0] + PARK_PITCH * col, PARK_ORIGIN[1] - PARK_PITCH * row, PARK_Z)


def geom_name(slot: int, family: str) -> str:
    """Name of the geom of shape-and-pose `family` (or "label") in slot `slot`."""
    return f"item_{slot}_{family}"


def _fmt(values) -> str:
    return " ".join(f"{v:.6g}" for v in values)


def _placeholder(catalogue: Catalogue, family: str) -> tuple[tuple[float, ...], tuple]:
    """(size, friction) of the catalogue's largest type of a family, to stand in the file."""
    members = [t for t in catalogue.types if t.family == family]
    if not members:
        shape = family.split("_")[0]
        return (0.05,) * (3 if shape == "box" else 2), (0.5, 0.005, 0.0001)
    largest = max(members, key=lambda t: (math.prod(t.size), t.name))
    return largest.size, largest.friction


def _geom(slot: int, family: str, catalogue: Catalogue) -> str:
    round_lying = family.endswith("_lying")
    quat = f' quat="{_fmt(LYING_QUAT)}"' if round_lying else ""
    size, friction = _placeholder(catalogue, family)
    return (
        f'      <geom name="{geom_name(slot, family)}" type="{family.split("_")[0]}" '
        f'size="{_fmt(size)}"{quat} condim="{6 if round_lying else 3}" '
        f'friction="{_fmt(friction)}"/>'
    )


def _body(slot: int, catalogue: Catalogue) -> str:
    first = catalogue.types[0]
    lines = [
        f'    <body name="item_{slot}" pos="{_fmt(park_position(slot))}" gravcomp="1">',
        f'      <freejoint name="item_{slot}_joint"/>',
        # Placeholder inertia: sim.cell.item_pool writes the spawned type's mass and inertia.
        f'      <inertial pos="0 0 0" mass="{first.mass:.6g}" diaginertia="1e-5 1e-5 1e-5"/>',
    ]
    lines += [_geom(slot, family, catalogue) for family in FAMILIES]
    # The label never collides (the class's contype and conaffinity 0 are never switched).
    lines.append(f'      <geom name="{geom_name(slot, LABEL)}" type="cylinder" size="0.03 0.03"/>')
    lines.append("    </body>")
    return "\n".join(lines)


def pool_xml(catalogue: Catalogue, pool_size: int = POOL_SIZE) -> str:
    """The MJCF text of the item pool."""
    bodies = "\n".join(_body(slot, catalogue) for slot in range(pool_size))
    welds = "\n".join(
        f'    <weld name="item_{slot}_grip" body1="{CUP_BODY}" body2="item_{slot}" '
        f'active="false" solref="{GRIP_SOLREF}"/>'
        for slot in range(pool_size)
    )
    return f"""<!-- Generated by `python -m sim.model.item_pool_xml` from sim/data/items.toml;
     do not edit. {pool_size} item bodies, one geom per shape-and-pose family and a
     label each (see sim/model/item_pool_xml.py). -->
<mujoco model="items">
  <option>
    <flag sleep="enable"/>
  </option>

  <default>
    <default class="item">
      <geom contype="0" conaffinity="0" group="{HIDDEN_GROUP}" rgba="1 1 1 0" margin="0"
        priority="1" solref="0.004 1"/>
    </default>
  </default>

  <worldbody>
    <frame childclass="item">
{bodies}
    </frame>
  </worldbody>

  <equality>
{welds}
  </equality>
</mujoco>
"""


def write(path: Path = ITEMS_XML) -> Path:
    """Rewrites the pool file from the catalogue; returns its path."""
    path.write_text(pool_xml(load_catalogue()))
    return path


if __name__ == "__main__":
    print(f"wrote {write()}", file=sys.stderr)
