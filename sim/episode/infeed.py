"""The infeed: items dropped onto the belt at their times, one held back while it would drop
into an item already there.

The flow places each item as if it rode with the belt from its drop on, clear of the items
before it (`sim.flow.generator`), and hands it over at the belt's speed. An item that has not
kept its place (a lying can or bottle that rolled back off the flat item it was dropped on, one
knocked upstream) can lie where the next item is dropped: spawned inside it, MuJoCo pushes the
two apart with the force of a deep penetration and throws one of them off the belt (most of
the items a four-robot line at 3.3 items/s lost, `docs/line.md`). A real feeder cannot drop an
item into another. With `[belt] infeed_hold`, an item just dropped that penetrates another item
deeper than `DEEP_M` (`Items.inside_another`) is taken back and dropped at the infeed's end a
step later, until it drops clear (after `MAX_HOLD_S` it is dropped onto what is still there);
the items due after it drop as planned meanwhile. Shallower overlaps (a few millimetres,
frequent at a line's densities) are left to the contact solver, which separates them without
carrying either back past the infeed.

`Infeed` is one of the episode's scheduled events (`sim.episode.scheduler`): due when an item's
time has come or one is held back.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from sim.cell.items import Items
from sim.cell.riding import ItemRiding
from sim.flow.config import X_INFEED
from sim.results.metrics import EpisodeMetrics

DEEP_M = 0.004
"""An item dropped into another deeper than this is held back [m]. The items' contacts push an
overlap apart at about 0.07 m/s per millimetre (relative to the belt): a lying can set 4 mm into
a lying bottle rolls back 2 mm upstream at x1, 6 mm sends it 2 cm, 1 cm 14 cm
(`tests/test_infeed.py`), and a can dropped 9.9 mm into a bottle rolled back off the infeed's
end (three robots at x1.5, seed 554640050)."""
MAX_HOLD_S = 2.0
"""Longest time one item is held back [s] (the belt carries the longest item, 0.35 m, past in
1.9 s at x1); then what still lies there is stuck (a jam at the infeed) and the item is dropped
onto it, raised in steps of `RAISE_STEP_M` until it clears it."""
RAISE_STEP_M = 0.01
"""Step by which an item that waited `MAX_HOLD_S` is raised above the item in its way [m]."""
MAX_RAISE_M = 0.2
"""Highest it is raised [m] (above the tallest item standing)."""


class Infeed:
    """Drops the flow's items onto the belt at their times.

    Args:
        items: The cell's items.
        flow: The episode's flow (`sim.flow.generator.Flow`).
        hold: Hold back an item that would drop into another (`[belt] infeed_hold`).
        riding: The items' riding (an item dropped partly onto a flat one wakes that one).
        metrics: Where the items dropped are booked as entered.
    """

    def __init__(self, items: Items, flow, hold: bool, riding: ItemRiding, metrics: EpisodeMetrics):
        self.items, self.flow, self.hold = items, flow, bool(hold)
        self.riding, self.metrics = riding, metrics
        self.next_index = 0
        """Flow index of the next item to drop."""
        self.holds = 0
        """Items held back at least once."""
        self.waiting: dict[int, float] = {}
        """Flow index of each item held back -> since when [s]."""
        self.clock: tuple[float, float, float] | None = None
        """(since [s], the flow's time then [s], its rate) while a belt fault has made the
        infeed run at a rate other than 1 (`run_at`); None: the flow's times are the drops'."""

    def run_at(self, t: float, rate: float) -> None:
        """From sim time `t` [s] the infeed runs at `rate` times its speed (0: stopped with the
        belt): the flow's times pass that much slower, the drops shift with them."""
        self.clock = (t, self.flow_time(t), float(rate))

    def flow_time(self, t: float) -> float:
        """The flow's time at sim time `t` [s]: `t` but after a belt fault."""
        if self.clock is None:
            return t
        since, at, rate = self.clock
        return at + rate * (t - since)

    def drop_time(self, i: int) -> float:
        """When flow item `i` drops [s] (inf while the infeed stands before it)."""
        t_spawn = float(self.flow.t_spawn[i])
        if self.clock is None:
            return t_spawn
        since, at, rate = self.clock
        if t_spawn <= at:
            return since
        return since + (t_spawn - at) / rate if rate > 0 else math.inf

    @property
    def pending(self) -> bool:
        """Items still to drop (due later, or held back)."""
        return self.next_index < len(self.flow) or bool(self.waiting)

    def due(self, t: float) -> bool:
        """Whether an item drops at sim time `t` [s] (its time has come, or one is held)."""
        if self.clock is not None:
            return bool(self.waiting) or (
                self.next_index < len(self.flow) and self.drop_time(self.next_index) <= t
            )
        return bool(self.waiting) or (
            self.next_index < len(self.flow) and self.flow.t_spawn[self.next_index] <= t
        )

    def next_time(self, t: float) -> float | None:
        """When the infeed acts next [s]: now while an item is held back, else the next
        item's time; None when every item has dropped."""
        if self.waiting:
            return t
        if self.next_index < len(self.flow):
            when = self.drop_time(self.next_index)
            return when if math.isfinite(when) else None
        return None

    def fire(self, parts: object) -> None:
        """Hand the due items over to the belt (at its speed, as from an infeed conveyor) and
        book them as entered; an item dropped partly onto a flat one wakes that one."""
        first, flow, items = self.next_index, self.flow, self.items
        dropped: Sequence[int]
        if self.hold:
            self.next_index, dropped = self._feed_holding(first)
        elif self.clock is not None:
            self.next_index, dropped = self._feed_shifted(first)
        else:
            self.next_index = items.feed(flow, first)
            dropped = range(first, self.next_index)
        items.kinematics()  # poses of the new items for the checks
        landing = [i for i in dropped if flow.z_drop[i] > 0]
        if landing:
            self.riding.wake_near(items.current(), [items.slot_of(i) for i in landing])
        for i in dropped:
            self.metrics.on_entered(i, int(flow.class_id[i]))

    def _feed_holding(self, first: int) -> tuple[int, list[int]]:
        """`Items.feed`, holding back an item that would drop into an item on the belt: it
        drops at the infeed's end once it drops clear (or has waited `MAX_HOLD_S`), while the
        items due after it drop as planned. Returns the next flow index and the items dropped
        now."""
        items, flow = self.items, self.flow
        t, i = items.time, first
        dropped, waiting = [], {}
        due = [(k, X_INFEED, since) for k, since in self.waiting.items()]
        while i < len(flow) and self.drop_time(i) <= t:
            due.append((i, X_INFEED + items.pool.belt.speed * (t - self.drop_time(i)), t))
            i += 1
        for k, x, since in due:
            slot = items.drop(flow, k, x)
            items.kinematics()
            if items.inside_another(slot, DEEP_M):
                if t - since < MAX_HOLD_S:
                    items.park(slot)
                    self.holds += k not in self.waiting
                    waiting[k] = since
                    continue
                # Waited long enough (an item stuck at the infeed): dropped onto it instead.
                self.drop_above(k, x, slot)
            dropped.append(k)
        self.waiting = waiting
        return i, dropped

    def _feed_shifted(self, first: int) -> tuple[int, list[int]]:
        """`Items.feed` at the drop times a belt fault has shifted: the next flow index and
        the items dropped now."""
        items, t, i = self.items, self.items.time, first
        while i < len(self.flow) and self.drop_time(i) <= t:
            items.drop(self.flow, i, X_INFEED + items.pool.belt.speed * (t - self.drop_time(i)))
            i += 1
        return i, list(range(first, i))

    def drop_above(self, k: int, x: float, slot: int) -> None:
        """Drop flow item `k`, which lies in `slot` inside another item, raised in steps of
        `RAISE_STEP_M` until it clears every item (at most `MAX_RAISE_M`), as off a chute.

        Args:
            k: Flow index of the item.
            x: Where along the belt it drops [m].
            slot: The pool slot it lies in now.
        """
        items = self.items
        lift = 0.0
        while True:
            items.park(slot)
            lift += RAISE_STEP_M
            slot = items.drop(self.flow, k, x, raise_m=lift)
            items.kinematics()
            if lift >= MAX_RAISE_M or not items.inside_another(slot, DEEP_M):
                return
