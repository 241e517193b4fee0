"""The whole-flow profit bound (`planner.decision.flow_bound`): its value on a hand-made flow,
and that no physics run on a small flow earns more than it."""

from __future__ import annotations

import numpy as np
import pytest

from planner.decision.flow_bound import interval_bound
from planner.errors import PlannerInputError


def test_the_bound_of_a_hand_made_flow():
    """Three items share the window [0, 1] s, one more is alone in [5, 6] s; a meeting takes
    at least 0.2 + 0.4 = 0.6 s from the last, so two of the three fit (floor(1 / 0.6) + 1 = 2):
    the 3 and 2 EUR ones, and the lone 4 EUR one: 9 EUR."""
    release = np.array([0.0, 0.0, 0.0, 5.0])
    deadline = np.array([1.0, 1.0, 1.0, 6.0])
    values = np.array([1.0, 2.0, 3.0, 4.0])
    bound = interval_bound(release, deadline, values, np.full(4, 0.2), np.full(4, 0.4))
    assert bound.bound == pytest.approx(9.0, abs=1e-9)
    assert bound.reachable_value == pytest.approx(10.0)
    assert bound.gap_s == pytest.approx(0.6)


def test_busy_times_cut_where_the_count_does_not():
    """Four 3 EUR items in [0, 2] s: with 0.9 s of least busy time each (K 0.3, P 0.6) the
    count allows floor(2 / 0.9) + 1 = 3 and the time (4 x 0.9 > 2 + 0.9) forbids four: 9 EUR;
    with 0.6 s each both allow all four: 12 EUR."""
    release, deadline = np.zeros(4), np.full(4, 2.0)
    bound = interval_bound(release, deadline, np.full(4, 3.0), np.full(4, 0.3), np.full(4, 0.6))
    assert bound.bound == pytest.approx(9.0, abs=1e-9)
    loose = interval_bound(release, deadline, np.full(4, 3.0), np.full(4, 0.1), np.full(4, 0.5))
    assert loose.bound == pytest.approx(12.0, abs=1e-9)  # 0.6 s each: count 4, time 2.4 <= 2.6


def test_items_out_of_reach_or_worthless_earn_nothing():
    bound = interval_bound(
        np.array([np.nan, 0.0]),
        np.array([np.nan, 1.0]),
        np.array([5.0, 0.0]),
        np.zeros(2),
        np.zeros(2),
    )
    assert bound.bound == 0.0


def test_bad_times_are_refused():
    with pytest.raises(PlannerInputError, match="pick_s"):
        interval_bound(np.zeros(1), np.ones(1), np.ones(1), np.array([-0.1]), np.zeros(1))


@pytest.mark.parametrize("pause_s", [0.0, 0.5])
def test_no_physics_run_earns_more_than_the_bound(pause_s):
    """30 items over 12 s at x1 (seed 3), both regimes: proximity and the best known order
    replayed in physics earn no more than the bound on their flow (checked, not proven: the bound
    holds under the cycle-time model)."""
    from sim.config import from_dict
    from sim.episode.runner import run_episode
    from sim.evaluation.flow_bound import best_order, bound_of, flow_facts, replay

    config = from_dict(
        {
            "perception": "truth",
            "seed": 3,
            "items": 30,
            "duration_s": 12.0,
            "planner": "proximity",
            "robot": {"pick_pause_s": pause_s, "place_pause_s": pause_s},
        }
    )
    facts = flow_facts(config)
    bound = bound_of(facts)
    order, kinematic = best_order(facts)
    assert kinematic <= bound.bound + 1e-6
    proximity = run_episode(config).episode_row["profit_eur"]
    replayed = replay(config, facts, order)
    assert replayed["followed"] > 0
    for profit in (proximity, replayed["profit_eur"]):
        assert profit <= bound.bound + 1e-6
    # The planner `best_order` finds the same order from the episode's flow and plays it alike.
    planned = run_episode(config.replace(planner="best_order")).episode_row
    assert planned["planner"] == "best_order"
    assert planned["profit_eur"] == replayed["profit_eur"]
