"""Closed-loop episodes that must lose items: missed, dropped, in the wrong bin, at the time cap.

A short episode on a light belt picks everything, so the loop's bookkeeping of losses never runs
there. Here, in physics (truth perception, proximity manager):

- Lossy cell: 30 items in 10 s at x1.5 (0.2775 m/s, 10.8 items per metre), more than the robot
  can pick, so items pass it unpicked (missed). The paper bin's release point is moved 0.38 m
  along the belt, beside the bin, so every paper item the robot carries falls on the floor
  (dropped), and the plastic items are released over the aluminium bin (wrong bin). Each item
  must end in exactly one of binned, missed, dropped; entered = picked + missed + dropped
  (wrong_bin is part of picked), and the profit is the aluminium items' value alone.
- Stalled belt: the belt stops once the first item is tracked and the decisions are all
  "nothing now", so the items stay on the belt until the episode's time cap, where the loop
  counts every one of them as missed.
"""

from __future__ import annotations

import numpy as np
import pytest

from perception.codes import ALUMINIUM, PAPER, PLASTIC
from sim import config
from sim.episode.loop import Episode

LOSSY = dict(
    items=30, duration_s=10.0, speed_factor=1.5, perception="truth", planner="proximity", seed=1
)
PAPER_OFFSET = np.array([0.38, 0.06, 0.0])  # [m] from the paper bin's release point


@pytest.fixture(scope="module")
def lossy(cell):
    """The finished lossy episode (the cell's release points restored afterwards)."""
    saved = {k: v.copy() for k, v in cell.robots[0].drop_xyz.items()}
    try:
        cell.robots[0].drop_xyz[PAPER] = saved[PAPER] + PAPER_OFFSET
        cell.robots[0].drop_xyz[PLASTIC] = saved[ALUMINIUM].copy()
        with Episode(config.load(None, **LOSSY), cell) as episode:
            episode.reset()
            episode.run()
        return episode
    finally:
        cell.robots[0].drop_xyz.update(saved)


def test_the_release_point_beside_the_paper_bin_is_over_no_bin(lossy):
    low, high = lossy.parts.bins.interiors["paper"]
    mid_z = 0.5 * (low[2] + high[2])
    release = np.array(lossy.cell.robots[0].bins_tuple()[0])
    moved = release + PAPER_OFFSET
    assert lossy.parts.bins.bin_at((release[0], release[1], mid_z)) == "paper"
    assert lossy.parts.bins.bin_at((moved[0], moved[1], mid_z)) is None
    assert moved[0] > high[0] + 0.1  # 18 cm past the paper bin's end wall


def test_the_episode_misses_drops_and_misplaces_items(lossy):
    row = lossy.metrics.row()
    assert row["entered"] == 30
    assert row["missed"] >= 5, row
    assert row["dropped"] >= 5, row
    assert row["wrong_bin"] >= 3, row
    assert row["picked"] >= 8, row
    # Ended normally: the missed were discarded on the way.
    assert lossy.data.time < lossy.parts.timeline.t_cap


def test_every_item_ends_in_exactly_one_place(lossy):
    m = lossy.metrics
    binned, missed, dropped = set(m.binned), m.missed, m.dropped
    assert not binned & missed and not binned & dropped and not missed & dropped
    assert binned | missed | dropped == set(range(30))
    row = m.row()
    assert row["entered"] == row["picked"] + row["missed"] + row["dropped"]
    assert row["picked"] == len(binned) and row["missed"] == len(missed)
    assert row["dropped"] == len(dropped)
    entered = row["entered_paper"] + row["entered_plastic"] + row["entered_aluminium"]
    picked = row["picked_paper"] + row["picked_plastic"] + row["picked_aluminium"]
    assert entered == row["entered"] and picked == row["picked"]
    assert row["accuracy"] == pytest.approx(row["picked"] / 30, abs=1e-12)
    assert not lossy.cell.pool.active_slots().size  # nothing left on the belt


def test_where_each_class_went(lossy):
    m, flow = lossy.metrics, lossy.parts.flow
    row = m.row()
    # Paper: released beside its bin, so never binned; every dropped item is a paper item.
    assert row["picked_paper"] == 0
    assert {int(flow.class_id[i]) for i in m.dropped} == {PAPER}
    # Plastic: binned in the aluminium bin, every one of them a wrong bin.
    assert row["picked_plastic"] >= 3
    assert row["wrong_bin"] == row["picked_plastic"]
    for item_id, (true_class, bin_class) in m.binned.items():
        assert bin_class == ALUMINIUM, (item_id, true_class, bin_class)
    # Profit: only aluminium in the aluminium bin earns (0.27 EUR each).
    assert row["picked_aluminium"] >= 3
    assert row["profit_eur"] == pytest.approx(0.27 * row["picked_aluminium"], abs=1e-9)


def test_dropped_items_were_carried_and_missed_ones_never_were(lossy):
    m = lossy.metrics
    carried = {p.item_id for p in m.picks if p.success}
    assert m.dropped <= carried  # released by the cup, beside the bin
    assert not m.missed & carried
    for landing in lossy.parts.bins.dropped:  # on the floor near the release point
        x, y, _ = landing.position
        target = lossy.cell.robots[0].drop_xyz[PAPER] + PAPER_OFFSET
        assert abs(x - target[0]) < 0.15 and abs(y - target[1]) < 0.15, landing
    assert len(lossy.parts.bins.dropped) == len(m.dropped)


def test_items_still_on_a_stalled_belt_at_the_time_cap_count_as_missed(cell):
    c = config.load(
        None,
        items=4,
        duration_s=2.0,
        speed_factor=1.5,
        perception="truth",
        planner="proximity",
        seed=2,
        item_riding="contact",  # items carried by friction alone, so the stopped belt holds them
    )
    before_cap = []
    with Episode(c, cell) as episode:
        episode.reset()
        stalled_at = None
        while episode.step_until_decision():
            if stalled_at is None:
                stalled_at = float(episode.data.time)
                cell.model.geom_surfacevel[cell.belt.geom_id, 0] = 0.0
            before_cap.append((len(episode.metrics.missed), len(cell.pool.active_slots())))
            episode.apply(None)
    row = episode.metrics.row()
    assert stalled_at is not None and stalled_at < 6.0
    assert before_cap[-1] == (0, 4)  # at the last decision: nothing missed yet, all on the belt
    assert episode.data.time >= episode.parts.timeline.t_cap
    assert episode.data.time < episode.parts.timeline.t_cap + 0.1
    assert row["entered"] == 4 and row["missed"] == 4
    assert row["picked"] == 0 and row["dropped"] == 0 and row["attempts"] == 0
    assert not cell.pool.active_slots().size
