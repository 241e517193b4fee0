"""The item checks of an episode, every `CHECK_PERIOD_S` of simulated time, in this order:
MuJoCo's new warnings and items thrown off the belt (`sim.monitors.thrown`), items out of every
robot's reach or past the belt's end (missed), items come to rest in a bin or elsewhere
(`sim.monitors.bins`), tracks gone past the robots, and which settled items ride the belt
(`sim.cell.riding`).

They run as one periodic event (`run_checks`, one of `sim.episode.builder.own_events`) on the
episode's parts (`sim.episode.parts.EpisodeParts`) and the items as read once at each check
(`Items.now`).
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np

from sim.cell.cell import Cell
from sim.cell.held_slots import held_mask
from sim.cell.items import Items, ItemsNow
from sim.flow.ground_truth import yaw_from_xmat
from sim.monitors.bins import Bins
from sim.sensing.attribution import attributed_item
from sim.sensing.confidence import is_unsure

if TYPE_CHECKING:
    from sim.episode.parts import EpisodeParts

log = logging.getLogger("sim.episode.loop")

BELOW_BELT_Z = -0.1
"""An item whose centre is this far below the belt surface has left it [m]."""


def episode_bins(cell: Cell) -> Bins:
    """The bins of every robot of `cell`."""
    return Bins(cell.model, cell.items, cell.materials, tuple(r.prefix for r in cell.robots))


def yaw_of(items: Items, slot: int) -> float:
    """Heading of the item's body in `slot` about z [rad]."""
    return float(yaw_from_xmat(items.orientation(slot)[None])[0])


def warnings_and_throws(parts: EpisodeParts, now: ItemsNow, held: np.ndarray) -> None:
    """MuJoCo's new warnings (a `MujocoWarning` names them), then the items thrown off the
    belt; items a cup let go of over a bin fall into it: never judged as thrown."""
    metrics, watch = parts.metrics, parts.throw_watch
    metrics.on_warnings(parts.mj_warnings.update())
    for station in parts.stations:
        for event in station.new_cup_events():
            if event.kind == "released":
                watch.note_released(event.item_id)
    for throw in watch.update(parts.cell.items, held, now):
        doing = "; ".join(s.robot.activity() for s in parts.stations)
        metrics.on_thrown(throw, doing)
        log.warning(
            "seed %d, t %.2f s: item %d thrown off the belt (%s) while the robot was at %s",
            parts.config.seed,
            throw.time,
            throw.item_id,
            throw.reason,
            doing,
        )


def out_of_reach(parts: EpisodeParts, now: ItemsNow, held: np.ndarray) -> bool:
    """Items past every robot's reach (not held), and items past the belt's end: missed.
    Returns whether any was."""
    items, metrics, tracker = parts.cell.items, parts.metrics, parts.tracker
    active, pos = now.slots, now.positions
    x_end = items.pool.belt.geometry.x_discharge
    if not len(active) or pos[:, 0].max() <= min(parts.timeline.x_discard, x_end):
        return False  # every item short of both lines
    passed = (pos[:, 0] > parts.timeline.x_discard) & (pos[:, 2] > BELOW_BELT_Z)
    discarded = passed & ~held_mask(active, held)
    # Past the belt's end (e.g. pushed along), of those still in play.
    beyond = ~discarded & (pos[:, 0] > x_end)
    gone = (*active[discarded].tolist(), *active[beyond].tolist())
    for slot in gone:
        item_id = items.park(slot)
        metrics.on_missed(item_id)
        book_unsure(parts, tracker.remove_true(item_id))
    return bool(gone)


def landings(parts: EpisodeParts, now: ItemsNow, held: np.ndarray) -> bool:
    """Items come to rest: in a bin (picked, if a cup let go of it there) or dropped. Returns
    whether any did (and was parked)."""
    metrics, released = parts.metrics, parts.throw_watch.released
    landed = parts.bins.update(parts.cell.items, held, now)
    for landing in landed:
        if landing.bin is None or landing.item_id not in released:
            # Only what the cup carried and let go of over a bin is picked; an item that
            # reached a bin otherwise (knocked off the belt) is dropped.
            metrics.on_dropped(landing.item_id)
        else:
            assert landing.bin_class is not None  # in a bin: its material's class
            metrics.on_binned(landing.item_id, landing.true_class, landing.bin_class)
        parts.tracker.remove_true(landing.item_id)
    return bool(landed)


def gone_tracks(parts: EpisodeParts, now: ItemsNow, held: np.ndarray) -> None:
    """Tracks gone past the robots unpicked."""
    book_unsure(parts, parts.tracker.prune(now.time, parts.timeline.x_discard))


def riding(parts: EpisodeParts, now: ItemsNow, held: np.ndarray) -> None:
    """Which settled items ride the belt, away from the paths of the picks under way."""
    paths = [s.path for s in parts.stations if s.robot.busy and s.path is not None]
    data = parts.cell.items.current()
    parts.riding.update(data, held, busy_paths=paths, now=now)


CHECKS = (warnings_and_throws, out_of_reach, landings, gone_tracks, riding)
"""The checks, in the order they run; a check that returns True has parked items."""


def run_checks(parts: EpisodeParts) -> None:
    """Every check of `CHECKS` in order, on the items as read once at this moment (the checks
    after one that parked items see them out of play) and the slots the cups hold (no check
    changes what a cup holds)."""
    pool = parts.cell.pool
    now, held = parts.cell.items.now(), parts.held()
    for check in CHECKS:
        if check(parts, now, held):
            now = now.in_play(pool)


def attribute(parts: EpisodeParts, created: list, t: float) -> None:
    """Book the true items the new tracks `created` at sim time `t` [s] are of (the metrics'
    `never_detected`; `sim.sensing.attribution`: bookkeeping the robot never sees)."""
    if not created:
        return
    items_xy, shapes = {}, {}
    if any(track.true_id is None for track in created):
        items = parts.cell.items
        held = parts.held()
        for slot in items.active_slots():
            if slot not in held:
                x, y = items.position(slot)[:2]
                item_id = int(items.pool.item_ids[slot])
                items_xy[item_id] = (float(x), float(y))
                shapes[item_id] = (yaw_of(items, int(slot)), items.pool.item_type(int(slot)))
    gate = parts.tracker.match_radius
    for track in created:
        detected = attributed_item(track, t, parts.speed, items_xy, gate, shapes)
        if detected is not None:
            parts.metrics.on_detected(detected)


def book_unsure(parts: EpisodeParts, gone: list) -> None:
    """Count the tracks among `gone` (went past the robots unpicked, or still tracked at the
    end) that the confidence rule kept from the decision managers (`left_unsure`)."""
    threshold = parts.config.applied_min_class_confidence
    parts.metrics.on_left_unsure(sum(1 for tr in gone if is_unsure(tr.probs, threshold)))
