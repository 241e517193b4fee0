"""The oracle: exact where its search finishes, a proven relaxation bound where it does not."""

from __future__ import annotations

import numpy as np
import pytest

from planner.decision.evaluation import short_belt
from planner.decision.interface import DecisionContext, RobotState, TrackedItem
from planner.decision.kinematic_belt import (
    THESIS_SPEED_X1,
    oracle_bound,
    random_belt,
    simulate,
)
from planner.decision.oracle import (
    SequenceSearch,
    best_sequence,
    pick_lower_bound,
    place_lower_bound,
    slot_bound,
)
from planner.decision.registry import make_planner
from planner.errors import PlannerInputError
from planner.motion.straight_line_timing import StraightLineCycleModel
from sim.episode.decision_view import cell_context


def _contexts():
    fitted = cell_context(0.222)
    straight = DecisionContext(
        0.222, StraightLineCycleModel(a_max=20.0), fitted.window, fitted.bins
    )
    return fitted, straight


@pytest.mark.parametrize("which", [0, 1])
def test_the_time_lower_bounds_hold_wherever_the_item_is_met(which):
    ctx = _contexts()[which]
    model, z = ctx.cycle_model, ctx.window.pick_z
    rng = np.random.default_rng(which)
    slack = []
    for _ in range(3000):
        x, y = rng.uniform(-0.7, 0.7), rng.uniform(-0.45, 0.45)
        start = (rng.uniform(-0.3, 0.3), rng.uniform(-0.6, 0.6), rng.uniform(0.02, 0.2))
        start = ctx.bins[rng.integers(3)] if rng.random() < 0.5 else start
        c = int(rng.integers(2, 5))
        slack.append(
            model.time_to_pick(start, (x, y), ctx.belt_speed) - pick_lower_bound(ctx, start, y)
        )
        slack.append(model.time_to_place((x, y, z), ctx.bin_of(c)) - place_lower_bound(ctx, y, c))
    assert min(slack) >= -1e-12
    assert np.median(slack) < 0.3  # and they are not vacuous


def test_slot_bound_by_hand():
    values = [0.27, 0.25, 0.22, 0.22]
    exits = [0.5, 0.5, 2.0, 0.1]
    # Slots at t = 0, 0.4, 0.8, ...: items 0 and 1 (exit 0.5) share slots 0 and 1, item 2 takes
    # the latest before 2.0 (slot 4) and item 3 (exit 0.1) finds slot 0 taken: 0.27+0.25+0.22.
    assert slot_bound([0, 1, 2, 3], values, exits, 0.0, 0.4) == pytest.approx(0.74)
    assert slot_bound([0, 1, 2, 3], values, exits, 0.0, 0.0) == pytest.approx(0.96)
    assert slot_bound([2, 3], values, exits, 0.2, 0.4) == pytest.approx(0.22)  # 3 has left


def test_the_relaxation_bounds_the_exact_optimum():
    for seed in range(30):
        belt = short_belt(seed)
        ctx = cell_context(belt.speed)
        plan = oracle_bound(belt, ctx)
        assert plan.exact and plan.bound == plan.profit and plan.bound_kind == "exact"
        items = [TrackedItem.certain(i.item_id, i.x0, i.y, i.true_class) for i in belt.items]
        search = SequenceSearch(
            items,
            [ctx.value_of(i.true_class) for i in belt.items],
            [i.true_class for i in belt.items],
            RobotState((0.0, 0.0, 0.10), 0.0),
            ctx,
        )
        assert search.relaxation() >= plan.profit - 1e-12


def test_a_stopped_search_quotes_the_relaxation():
    belt = short_belt(3)
    ctx = cell_context(belt.speed)
    exact = oracle_bound(belt, ctx)
    stopped = oracle_bound(belt, ctx, max_nodes=5)
    assert not stopped.exact and stopped.bound_kind == "relaxation"
    assert stopped.profit <= exact.profit <= stopped.bound
    with pytest.raises(PlannerInputError):
        oracle_bound(belt, ctx, max_nodes=0)


def test_a_belt_too_large_for_the_search_still_has_a_true_bound():
    """118 items in 45 s: the search stops; the relaxation bounds every planner's profit."""
    belt = random_belt(np.random.default_rng(1), 118, 45 * THESIS_SPEED_X1, THESIS_SPEED_X1)
    ctx = cell_context(belt.speed)
    plan = oracle_bound(belt, ctx, max_nodes=2000)
    assert not plan.exact
    for name in ("lookahead", "fifo", "greedy"):
        assert simulate(make_planner(name), belt, ctx).profit <= plan.bound
    assert plan.bound < sum(ctx.value_of(i.true_class) for i in belt.items)


def test_an_unknown_timing_model_gets_the_sum_of_the_values_left():
    class Slow:
        def time_to_pick(self, start_xyz, item_xy, belt_speed):
            return 0.4

        def time_to_place(self, pick_xyz, bin_xyz):
            return 0.4

    fitted = cell_context(0.185)
    ctx = DecisionContext(0.185, Slow(), fitted.window, fitted.bins)
    items = [TrackedItem.certain(k, -0.1 * k, 0.0, 2 + k % 3) for k in range(5)]
    values = [ctx.expected_value(i) for i in items]
    plan = best_sequence(
        items, values, [i.bin_class for i in items], RobotState(ctx.bins[0], 0), ctx
    )
    search = SequenceSearch(
        items, values, [i.bin_class for i in items], RobotState(ctx.bins[0], 0.0), ctx
    )
    assert search.gap == 0.0 and search.relaxation() == pytest.approx(sum(values))
    assert plan.exact and plan.profit == pytest.approx(sum(values))  # 0.8 s a pick: all of them


def _brute_best_score(search: SequenceSearch, n: int) -> float:
    """The best score over every order of every non-empty subset of the items (by hand)."""
    import itertools

    best = -np.inf
    for size in range(1, n + 1):
        for order in itertools.permutations(range(n), size):
            where, t, profit = 0, search.t0, 0.0
            for j in order:
                if search.exits[j] <= t:
                    break
                end = search.pick_end(j, where, t)
                if end is None:
                    break
                profit, t, where = profit + search.values[j], end, 1 + search.bin_index[j]
            else:
                best = max(best, search.score(profit, t))
    return best


@pytest.mark.parametrize("seed", range(6))
def test_a_priced_search_finds_the_best_score(seed):
    """With the robot's time priced (the look-ahead's saturated belts), the finished search's
    order scores as the best of every order of every subset, found by hand; never empty."""
    belt = short_belt(seed, items=(5, 5))
    ctx = cell_context(belt.speed)
    items = [TrackedItem.certain(i.item_id, i.x0, i.y, i.true_class) for i in belt.items]
    args = (
        items,
        [ctx.value_of(i.true_class) for i in belt.items],
        [i.true_class for i in belt.items],
        RobotState((0.0, 0.0, 0.10), 0.0),
        ctx,
    )
    search = SequenceSearch(*args, time_price=0.4)
    assert search.run()
    assert search.best_seq
    assert search.best_score == pytest.approx(_brute_best_score(SequenceSearch(*args, 0.4), 5))
    with pytest.raises(PlannerInputError, match="time_price"):
        SequenceSearch(*args, time_price=-1.0)
