"""Bins register the items that come to rest inside them; items elsewhere off the belt drop."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.cell.conveyor import Belt
from sim.cell.held_slots import held_slots
from sim.cell.item_pool import ItemPool
from sim.cell.items import Items
from sim.flow.catalogue import load_catalogue
from sim.monitors.bins import Bins
from tests.utils import scene_at_home

CATALOGUE = load_catalogue()


def cell():
    model, data = scene_at_home()
    pool = ItemPool(model, CATALOGUE, Belt(model))
    return model, data, pool, Bins(model, Items(model, data, pool))


def run(model, data, bins, seconds, held_slot=None):
    records = []
    for _ in range(int(round(seconds / model.opt.timestep))):
        mujoco.mj_step(model, data)
        records += bins.update(Items(model, data, bins.pool), held_slots(held_slot))
    return records


def test_interiors_are_read_from_the_bin_geoms():
    _, _, _, bins = cell()
    low, high = bins.interiors["paper"]
    np.testing.assert_allclose(low, [-0.2, -0.73, -0.34], atol=1e-9)
    np.testing.assert_allclose(high, [0.2, -0.45, -0.05], atol=1e-9)
    assert bins.bin_at([0.21, 0.54, -0.3]) == "aluminium"
    assert bins.bin_at([0.0, 0.0, 0.0]) is None


def test_items_dropped_over_bins_register_with_class_and_time_and_are_parked():
    model, data, pool, bins = cell()
    can = CATALOGUE.index("can_330_lying")
    paper = CATALOGUE.index("paper_folded_a6")
    pool.spawn(data, 10, can, 0.21, 0.54, 0.0, CATALOGUE.rgba[3])  # aluminium bin: right
    pool.spawn(data, 11, paper, -0.21, 0.54, 0.0, CATALOGUE.rgba[2])  # plastic bin: wrong
    records = run(model, data, bins, 1.0)
    by_id = {r.item_id: r for r in records}
    assert set(by_id) == {10, 11} and not bins.dropped
    assert by_id[10].bin == "aluminium" and by_id[10].true_class == 4 and by_id[10].correct
    assert by_id[11].bin == "plastic" and by_id[11].true_class == 2 and not by_id[11].correct
    # Judged once at rest on the floor: fall time (~0.25 s) plus REST_TIME, well within 1 s.
    assert 0.3 < by_id[10].time < 0.8
    assert by_id[10].position[2] == pytest.approx(-0.34 + 0.033, abs=2e-3)
    assert len(pool.active_slots()) == 0


def test_items_falling_beside_the_bins_are_dropped_and_riding_or_held_items_are_not_judged():
    model, data, pool, bins = cell()
    box = CATALOGUE.index("carton_box_small")
    pool.spawn(data, 1, box, 0.6, -0.7, 0.0, CATALOGUE.rgba[1])  # beside the belt, no bin
    pool.spawn(data, 2, box, -1.0, 0.0, 0.0, CATALOGUE.rgba[1])  # riding the belt
    held = pool.spawn(data, 3, box, 0.0, -0.54, 0.0, CATALOGUE.rgba[1])  # over a bin, "held"
    records = run(model, data, bins, 1.0, held_slot=held)
    assert [(r.item_id, r.bin) for r in records] == [(1, None)]
    assert bins.dropped[0].true_class == 2
    assert pool.slot_of(2) is not None and pool.slot_of(3) is not None
