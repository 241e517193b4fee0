"""Which items a robot of a line sorts: the materials each robot takes.

A line's robot may sort only some of the catalogue's materials (an episode config's
`[[robots]]` table, `materials = [...]`). Such a robot is offered only the items whose most
probable material (`TrackedItem.bin_class`, class ids 2, 3, ... in the catalogue's order) it
sorts; the others ride on to the robots downstream. A robot given no materials sorts them all
(its class ids are None).

Pure functions of the tracked items and the class ids.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from perception.codes import Materials
from planner.decision.interface import TrackedItem
from planner.errors import PlannerInputError


def class_ids_of(names: Sequence[str] | None, materials: Materials) -> frozenset[int] | None:
    """The class ids (2, 3, ...) of the material `names` among `materials`; None for None
    (every material)."""
    if names is None:
        return None
    unknown = [n for n in names if n not in materials.names]
    if unknown:
        raise PlannerInputError("materials", ", ".join(materials.names), unknown)
    return frozenset(materials.id_of(n) for n in names)


def sorts(class_ids: frozenset[int] | None, item: TrackedItem) -> bool:
    """Whether a robot sorting the classes `class_ids` (None: all) takes `item`: its most
    probable material is one of them."""
    return class_ids is None or item.bin_class in class_ids


def items_sorted_by(
    items: Iterable[TrackedItem], class_ids: frozenset[int] | None
) -> list[TrackedItem]:
    """The `items` a robot sorting the classes `class_ids` (None: every material) is offered,
    in their order: those whose most probable material (`bin_class`) it sorts.

    Args:
        items: Tracked items (positions [m], class probabilities).
        class_ids: Material class ids the robot sorts (2, 3, ...), or None for all of them.
    """
    if class_ids is None:
        return list(items)
    return [item for item in items if sorts(class_ids, item)]
