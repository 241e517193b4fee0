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


def covering_stopped(
    class_ids: Sequence[frozenset[int] | None], stopped: Iterable[int]
) -> tuple[frozenset[int] | None, ...]:
    """Each robot's classes while the robots `stopped` (indices) are stopped: every robot still
    running takes the stopped robots' materials too (a line's robots each have a bin for every
    material), so their items are not lost for want of a sorter; a stopped robot keeps its own.

    Args:
        class_ids: Per robot, the material class ids it sorts (None: every material).
        stopped: The indices of the robots stopped now.
    """
    down = set(stopped)
    if not down:
        return tuple(class_ids)
    if any(class_ids[k] is None for k in down):
        return tuple(ids if k in down else None for k, ids in enumerate(class_ids))
    taken = frozenset().union(*(class_ids[k] or frozenset() for k in down))
    return tuple(
        ids if k in down or ids is None else ids | taken for k, ids in enumerate(class_ids)
    )
