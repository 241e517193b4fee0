"""Hand-made belts on which the decision managers must choose differently."""

from __future__ import annotations

import pytest

from planner.decision.candidates import candidates, intercept
from planner.decision.interface import RobotState, TrackedItem
from planner.decision.kinematic_belt import Belt, BeltItem, one_hot, oracle_bound, simulate
from planner.decision.registry import PLANNERS, make_planner
from sim.episode.decision_view import cell_context

V = 0.185
PAPER_BIN = (0.0, -0.56, 0.06)


def _belt(spec):
    items = tuple(BeltItem(i, x, y, c, one_hot(c)) for i, (x, y, c) in enumerate(spec))
    return Belt(items, V)


def _first_choices(belt, ctx, start):
    items = [TrackedItem(it.item_id, it.x0, it.y, it.class_probs) for it in belt.items]
    robot = RobotState(start, 0.0)
    return {name: make_planner(name).choose(items, robot, ctx).item_id for name in PLANNERS}


def _qlearning_firsts(belt, ctx, start, seeds=range(8)):
    items = [TrackedItem(it.item_id, it.x0, it.y, it.class_probs) for it in belt.items]
    robot = RobotState(start, 0.0)
    return [make_planner("qlearning", seed=s).choose(items, robot, ctx).item_id for s in seeds]


def test_far_aluminium_about_to_leave_versus_two_near_papers():
    """Robot at the paper bin. Aluminium 0 is far away and about to leave the window; papers 1
    and 2 are close and stay for seconds. Going for a paper first loses the aluminium; the best
    order is the aluminium, then paper 2, then paper 1."""
    ctx = cell_context(V)
    belt = _belt([(0.41, 0.30, 4), (-0.15, -0.28, 2), (-0.05, -0.33, 2)])
    first = _first_choices(belt, ctx, PAPER_BIN)
    assert first["fifo"] == 0  # the item leaving first
    assert first["proximity"] == 2  # the nearest
    assert first["rollout"] == 2  # highest v/d rollout: near paper beats far aluminium
    assert first["greedy"] == 2  # 0.22 EUR in a short cycle beats 0.27 EUR in a long one
    assert first["lookahead"] == 0  # the best order, as the oracle's
    best = oracle_bound(belt, ctx, PAPER_BIN)
    assert best.sequence == (0, 2, 1) and best.exact
    assert best.profit == pytest.approx(0.22 + 0.27 + 0.22)
    profit = {n: simulate(make_planner(n), belt, ctx, PAPER_BIN).profit for n in PLANNERS}
    for name in ("seen_best", "fifo", "lookahead"):
        assert profit[name] == pytest.approx(0.71), name
    for name in ("proximity", "rollout", "greedy"):
        assert profit[name] == pytest.approx(0.44), name
    # The thesis's Q-learning picks by the q its random episodes left: the first pick depends on
    # the seed (and on nothing else: the same seed, the same pick).
    firsts = _qlearning_firsts(belt, ctx, PAPER_BIN)
    assert len(set(firsts)) > 1
    assert firsts == _qlearning_firsts(belt, ctx, PAPER_BIN)


def test_item_about_to_leave_the_window():
    """A plastic sits next to the robot; a paper is 0.1 m (0.54 s of belt travel) from the
    window's downstream edge on the far side. FIFO and seen_best go for the paper first and
    lose nothing; proximity, the rollout and greedy take the plastic and lose the paper."""
    ctx = cell_context(V)
    start = (-0.21, 0.51, 0.06)  # plastic bin
    x_exit = ctx.window.bounds(-0.25)[1]
    leaving = (x_exit - 0.10, -0.25, 2)
    belt = _belt([leaving, (-0.25, 0.3, 3), (-0.45, 0.0, 3)])
    met = intercept(ctx, start, 0.0, leaving[0], leaving[1])
    assert met is not None and not met[2]  # reachable now, without waiting
    first = _first_choices(belt, ctx, start)
    assert first["fifo"] == first["seen_best"] == first["lookahead"] == 0
    assert first["proximity"] == first["rollout"] == first["greedy"] == 1
    profit = {n: simulate(make_planner(n), belt, ctx, start).profit for n in PLANNERS}
    assert profit["fifo"] == pytest.approx(0.22 + 0.25 + 0.25)
    assert profit["seen_best"] == profit["lookahead"] == pytest.approx(0.72)
    for name in ("proximity", "rollout", "greedy"):
        assert profit[name] == pytest.approx(0.50), name
    assert len(set(_qlearning_firsts(belt, ctx, start))) > 1


def test_objective_variants_and_extreme_values_change_the_choice():
    """Near paper vs far aluminium with time for only one of them to matter: the rollout with
    v/d and v = 1 takes the paper, with d = 1 (value only) the aluminium, and raising
    aluminium's value by 150 makes it and greedy take the aluminium too. The thesis's
    Q-learning, myopic (gamma 0) and on value only, takes the aluminium: q is then the value."""
    ctx = cell_context(V)
    robot = RobotState(PAPER_BIN, 0.0)
    items = [TrackedItem.certain(0, 0.1, 0.30, 4), TrackedItem.certain(1, -0.05, -0.33, 2)]

    def pick(name, context=ctx, **kw):
        return make_planner(name, **kw).choose(items, robot, context).item_id

    assert pick("rollout") == 1
    assert pick("rollout", objective="v=1") == 1
    assert pick("rollout", objective="d=1") == 0
    assert pick("qlearning", objective="d=1", gamma=0.0) == 0
    assert pick("proximity") == 1
    rich = ctx.with_values((0.22, 0.25, 150.27))
    assert pick("rollout", rich) == 0
    assert pick("greedy", rich) == 0
    assert pick("proximity", rich) == 1  # blind to value


def test_candidates_leave_out_lost_items_and_mark_waits():
    ctx = cell_context(V)
    robot = RobotState(PAPER_BIN, 0.0)
    x_exit = ctx.window.bounds(0.0)[1]
    gone = TrackedItem.certain(0, x_exit + 0.01, 0.0, 4)
    too_late = TrackedItem.certain(1, x_exit - 0.01, 0.3, 4)  # the cup cannot get there in time
    upstream = TrackedItem.certain(2, -1.2, 0.0, 3)
    outside = TrackedItem.certain(3, 0.0, 0.75, 3)
    cands = candidates([gone, too_late, upstream, outside], robot, ctx)
    assert [c.item.item_id for c in cands] == [2]
    assert cands[0].waits and cands[0].meet_xy[0] == pytest.approx(ctx.window.bounds(0.0)[0])
    assert candidates([upstream], robot, ctx, immediate_only=True) == []
    assert make_planner("proximity").choose([upstream], robot, ctx) is None
    assert make_planner("greedy").choose([upstream], robot, ctx).item_id == 2


def test_every_choice_is_feasible_and_on_time():
    """On a busy belt every planner's choices are met inside the window, as predicted."""
    import numpy as np

    from planner.decision.kinematic_belt import random_belt

    ctx = cell_context(V)
    belt = random_belt(np.random.default_rng(3), 20, 1.0, V)
    for name in PLANNERS:
        result = simulate(make_planner(name), belt, ctx)
        assert result.picks, name
        for p in result.picks:
            assert p.decided <= p.meet < p.end
            item = next(i for i in belt.items if i.item_id == p.item_id)
            assert ctx.window.contains(item.x0 + V * p.meet, item.y)
        ends = [p.end for p in result.picks]
        assert ends == sorted(ends)
