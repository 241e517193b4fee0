"""The environments' slot candidates: the K most urgent feasible picks, found without timing
every item in view, are exactly the first K of the full candidate list."""

from __future__ import annotations

import numpy as np
import pytest

from planner.decision.candidates import candidates
from planner.decision.interface import RobotState, TrackedItem
from planner.decision.kinematic_belt import HOME_TCP, random_belt
from planner.decision.slot_features import slot_candidates
from sim.episode.decision_view import cell_context


@pytest.mark.parametrize("k_slots", [1, 3, 8])
def test_slot_candidates_are_the_most_urgent_k(k_slots):
    context = cell_context(0.185)
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(40):
        belt = random_belt(rng, int(rng.integers(5, 30)), 3.0, 0.185, start_x=0.4)
        t = float(rng.uniform(0.0, 12.0))
        tcp = tuple(HOME_TCP) if rng.random() < 0.5 else context.bins[int(rng.integers(3))]
        items = [
            TrackedItem(it.item_id, it.x0 + 0.185 * t, it.y, it.class_probs) for it in belt.items
        ]
        robot = RobotState(tcp, t)
        full = [c.item.item_id for c in candidates(items, robot, context)[:k_slots]]
        fast = [c.item.item_id for c in slot_candidates(items, robot, context, k_slots)]
        assert fast == full
        checked += bool(full)
    assert checked >= 20  # most draws had feasible picks to compare
