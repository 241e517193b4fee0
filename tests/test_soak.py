"""The soak's checks: accounting identities, and (slow) a few random episodes that pass them all.

`make soak` runs 200 random episodes through `sim.experiments.soak`; the slow test here runs six,
in this process, with the same checks: every count adds up, no MuJoCo warning, a finite state
throughout, no item thrown off the belt.
"""

from __future__ import annotations

import pytest

from perception.codes import ALUMINIUM, PAPER, PLASTIC
from sim.experiments.soak import (
    LINE_DENSITY_PER_M,
    LINE_ITEMS,
    PLANNERS,
    RIDINGS,
    SPEED_FACTORS,
    draw_configs,
    soak_episode,
)
from sim.flow.config import MAX_ITEMS_PER_METRE
from sim.monitors.thrown import Throw
from sim.results.metrics import EpisodeMetrics, PickRecord

VALUES = {PAPER: 0.22, PLASTIC: 0.25, ALUMINIUM: 0.27}


def _pick(item: int, success: bool = True) -> PickRecord:
    return PickRecord(0.0, 0.5, item, PAPER, PAPER, PAPER, success)


def _booked() -> EpisodeMetrics:
    """Four items: one picked into its bin, one into the wrong bin, one missed, one dropped."""
    m = EpisodeMetrics(VALUES)
    for item, cls in enumerate((PAPER, PLASTIC, ALUMINIUM, PAPER)):
        m.on_entered(item, cls)
    m.on_pick(_pick(0))
    m.on_binned(0, PAPER, PAPER)
    m.on_pick(_pick(1))
    m.on_binned(1, PLASTIC, ALUMINIUM)
    m.on_missed(2)
    m.on_pick(_pick(3, success=False))
    m.on_dropped(3)
    return m


def test_the_identities_hold_for_a_consistent_episode():
    m = _booked()
    assert m.accounting_failures() == []
    row = m.row()
    assert row["entered"] == row["picked"] + row["missed"] + row["dropped"] == 4
    assert row["wrong_bin"] == 1 and row["failed_picks"] == 1


def test_the_identities_catch_lost_double_and_unearned_bookings():
    lost = _booked()
    lost.on_entered(4, PAPER)  # entered, never booked anywhere
    assert any("entered 5" in f for f in lost.accounting_failures())
    twice = _booked()
    twice.dropped.add(2)  # missed and dropped
    assert any("overlap" in f for f in twice.accounting_failures())
    unearned = _booked()
    unearned.on_binned(2, ALUMINIUM, ALUMINIUM)  # in a bin with no pick that carried it
    unearned.missed.discard(2)
    assert any("carried to a bin" in f for f in unearned.accounting_failures())
    thrown = _booked()
    thrown.on_thrown(Throw(9, 1.0, "fast", (0.0, 0.0, 0.0), (2.0, 0.0, 0.0)), "idle")
    assert any("never booked" in f for f in thrown.accounting_failures())


def test_the_draw_spans_the_cell_within_the_flows_limits():
    configs = draw_configs(60, seed=7)
    assert configs == draw_configs(60, seed=7)  # reproducible
    assert {c.planner for c in configs} == set(PLANNERS)
    assert {c.item_riding for c in configs} == set(RIDINGS)
    assert {c.speed_factor for c in configs} == set(SPEED_FACTORS)
    assert all(c.perception == "truth" for c in configs)
    for c in configs:
        assert c.items <= MAX_ITEMS_PER_METRE * c.duration_s * c.belt_speed_mps + 1e-6


def test_the_line_draw_spans_robots_coordinations_and_dense_belts():
    configs = draw_configs(40, seed=7, lines=True)
    assert configs == draw_configs(40, seed=7, lines=True)
    assert {c.robot_count for c in configs} == {2, 3, 4}
    assert {c.coordination for c in configs} == {"independent", "coordinated"}
    assert {c.item_riding for c in configs} == set(RIDINGS)
    densities = [c.items / (c.duration_s * c.belt_speed_mps) for c in configs]
    assert max(densities) <= LINE_DENSITY_PER_M[1] + 1e-6
    assert sum(d > MAX_ITEMS_PER_METRE for d in densities) >= 30  # beyond one robot's belts
    items = [c.items for c in configs]
    assert LINE_ITEMS[0] - 2 <= min(items) and max(items) <= LINE_ITEMS[1] + 2  # rounding
    assert max(items) >= 300 and min(items) <= 200
    assert all(c.line_cell for c in configs)


@pytest.mark.slow
def test_six_random_episodes_pass_every_soak_check():
    for config in draw_configs(6, seed=2026, duration_s=(20.0, 35.0)):
        result = soak_episode(config)
        assert result.ok, result.line()
        assert result.row["thrown_off"] == 0 and result.row["mujoco_warnings"] == 0
