"""The rollout planner (ours, formerly run as `qlearning`): its reward path and q against hand
computations, batches, and the timed episodes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner.decision.batch_grid import batch_index, grid_column
from planner.decision.candidates import candidates
from planner.decision.interface import RobotState, TrackedItem
from planner.decision.managers.rollout import (
    RolloutConfig,
    RolloutPlanner,
    q_values,
    reward_path,
    weights,
)
from planner.errors import PlannerInputError
from sim.episode.decision_view import cell_context

# Rows: robot, paper bin, plastic bin, aluminium bin; items go to paper, plastic, aluminium.
REWARDS = np.array(
    [
        [0.50, 0.40, 0.30],
        [0.00, 0.60, 0.20],
        [0.10, 0.00, 0.35],
        [0.20, 0.45, 0.00],
    ]
)
NEXT = np.array([1, 2, 3])


def test_path_follows_rewards_and_stops_by_the_thesis_rule():
    # Start: item 0 (0.50, the most precious). From the paper bin 0.60 + 0.20 >= 0.50: go on,
    # item 1. From the plastic bin the rest is 0.35 < 0.50: stop.
    path, collected = reward_path(REWARDS, NEXT)
    assert path == [0, 1]
    assert collected == [0.50, 0.60]


def test_q_values_match_the_hand_computation():
    q, episodes = q_values(REWARDS, NEXT, gamma=0.9, iterations=50)
    # Episode 1: q1 = 0.6 (nothing after it yet), q0 = 0.5 + 0.9 * 0 (q1 still 0 when q0 was
    # updated). Episode 2: q0 = 0.5 + 0.9 * 0.6 = 1.04. Episode 3 changes nothing.
    assert q == pytest.approx([1.04, 0.60, 0.0], abs=1e-12)
    assert episodes == 3
    q1, _ = q_values(REWARDS, NEXT, gamma=0.9, iterations=1)
    assert q1 == pytest.approx([0.50, 0.60, 0.0], abs=1e-12)


def test_without_the_stopping_rule_firing_q_chains_over_the_whole_batch():
    rewards = REWARDS.copy()
    rewards[2, 2] = 0.55  # from the plastic bin, the last item is now worth going on for
    q, _ = q_values(rewards, NEXT, gamma=0.9, iterations=50)
    q2 = 0.55
    q1 = 0.60 + 0.9 * q2
    q0 = 0.50 + 0.9 * max(q1, q2)
    assert q == pytest.approx([q0, q1, q2], abs=1e-12)


def test_gamma_zero_is_myopic():
    q, _ = q_values(REWARDS, NEXT, gamma=0.0, iterations=50)
    assert q == pytest.approx([0.50, 0.60, 0.0])


def test_weights_are_value_over_robot_item_bin_distance():
    ctx = cell_context(0.185)
    robot = RobotState((0.0, 0.3, 0.06), 10.0)
    items = [
        TrackedItem.certain(7, 0.10, 0.20, 4),
        TrackedItem.certain(8, -0.20, -0.25, 2),
        TrackedItem.certain(9, 0.05, 0.0, 3),
    ]
    cands = candidates(items, robot, ctx)
    assert len(cands) == 3
    for objective in ("v/d", "d=1", "v=1"):
        w, nxt = weights(cands, robot, ctx, objective)
        for k, c in enumerate(cands):
            mx, my = c.meet_xy
            bx, by, _ = ctx.bin_of(c.bin_class)
            for s, (sx, sy) in enumerate([robot.tcp[:2], *(b[:2] for b in ctx.bins)]):
                d = math.hypot(mx - sx, my - sy) + math.hypot(bx - mx, by - my)
                v = ctx.value_of(c.bin_class)
                want = {"v/d": v / d, "d=1": v, "v=1": 1 / d}[objective]
                assert w[s, k] == pytest.approx(want, rel=1e-12)
            assert nxt[k] == c.bin_class - 1


# The picks of the timed rollout when it ran under the name qlearning (commit 58d5ab0) on
# random_belt(default_rng(4), 30 items, 1.5 m, 0.185 m/s).
PICKS_BEFORE = [3, 23, 7, 18, 29, 15, 5, 26, 24, 25, 4, 22, 11, 12, 1, 19, 20, 16, 13, 6, 14, 8]
PICKS_BEFORE += [17, 2, 0, 27, 10, 21]


def test_the_rollout_is_what_ran_as_qlearning_before():
    from dataclasses import replace

    from planner.decision.kinematic_belt import random_belt, simulate
    from planner.motion.cycle_model import PICK_COEF, PLACE_COEF

    # On the cycle-time model of that commit (the bare-pick calibration; the cell's model has
    # been calibrated on the physics' picks since: sim.episode.cycle_timing).
    ctx = cell_context(0.185)
    bare = replace(ctx.cycle_model, pick_coef=PICK_COEF, place_coef=PLACE_COEF)
    ctx = replace(ctx, cycle_model=bare)
    belt = random_belt(np.random.default_rng(4), 30, 1.5, 0.185)
    result = simulate(RolloutPlanner(), belt, ctx)
    assert RolloutPlanner.name == "rollout"
    assert [p.item_id for p in result.picks] == PICKS_BEFORE
    assert result.picks[0].meet == pytest.approx(1.305652, abs=1e-6)
    assert result.profit == pytest.approx(6.93)


def test_planner_picks_the_max_q_item_of_the_current_batch():
    ctx = cell_context(0.185)
    robot = RobotState((0.0, -0.51, 0.06), 3.0)
    items = [
        TrackedItem.certain(1, -0.05, -0.30, 2),  # paper next to the paper bin
        TrackedItem.certain(2, 0.10, 0.25, 4),
        TrackedItem.certain(3, -0.30, 0.0, 3),
    ]
    choice = RolloutPlanner().choose(items, robot, ctx)
    cands = candidates(items, robot, ctx, immediate_only=True)
    w, nxt = weights(cands, robot, ctx, "v/d")
    q, _ = q_values(w, nxt, 0.9, 50)
    assert choice.item_id == cands[int(np.argmax(q))].item.item_id == 1
    assert "max q" in choice.reason


def test_batches_are_20_rows_fixed_to_the_belt():
    cfg = RolloutConfig()
    v = 0.185
    pitch = v * cfg.row_period_s
    rows = (cfg.row_period_s, cfg.batch_rows)
    item = TrackedItem.certain(1, -0.5 * pitch, 0.0, 2)  # row 0 at t = 0
    assert batch_index(item, 0.0, v, *rows) == 0
    upstream = TrackedItem.certain(2, -20.5 * pitch, 0.0, 2)  # row 20
    assert batch_index(upstream, 0.0, v, *rows) == 1
    # Ten seconds later both moved 20 rows downstream with the belt: same rows, same batches.
    moved = TrackedItem.certain(2, -20.5 * pitch + 10.0 * v, 0.0, 2)
    assert batch_index(moved, 10.0, v, *rows) == 1
    # Rows counted from another origin: the item 20.5 rows upstream of it is in batch 1.
    assert batch_index(upstream, 0.0, v, *rows, origin=-1.0 * pitch) == 0
    assert batch_index(upstream, 0.0, v, *rows, origin=0.6 * pitch) == 1
    assert grid_column(-0.4) == 2 and grid_column(0.0) == 14 and grid_column(0.4) == 26


def test_an_earlier_batch_keeps_priority_over_a_better_later_one():
    ctx = cell_context(0.185)
    cfg = RolloutConfig(batch_rows=2)  # batches of 2 rows = 0.185 m so both are in reach
    pitch = 0.185 * cfg.row_period_s
    robot = RobotState((0.2, 0.51, 0.06), 0.0)
    downstream_paper = TrackedItem.certain(1, -0.5 * pitch, -0.3, 2)  # batch 0, far from robot
    upstream_alu = TrackedItem.certain(2, -2.5 * pitch, 0.35, 4)  # batch 1, next to the robot
    planner = RolloutPlanner(cfg)
    assert planner.choose([upstream_alu, downstream_paper], robot, ctx).item_id == 1
    # The first row is the first item seen: the same two items, seen first at another time,
    # are still two rows apart, so still in two batches.
    later = RobotState(robot.tcp, 0.3)
    moved = [
        TrackedItem(i.item_id, i.x + 0.185 * 0.3, i.y, i.class_probs)
        for i in (upstream_alu, downstream_paper)
    ]
    planner.reset()
    assert planner.choose(moved, later, ctx).item_id == 1
    choice = RolloutPlanner().choose([upstream_alu, downstream_paper], robot, ctx)
    assert choice.item_id == 2  # one 20-row batch: the close, valuable item wins


def test_episodes_in_time_beat_proximity_and_the_reward_path_on_dense_belts():
    """Seeded belts at table 4.6's densest regime (x1.2, 300 items over 135 s): the episodes in
    time earn more than the proximity picker belt by belt, and than q from the reward path alone
    over the four belts (not on each: on one of them the path earns 0.04 EUR more), on the
    cycle-time model's simulator."""
    from planner.decision.kinematic_belt import random_belt, simulate
    from planner.decision.registry import make_planner

    speed = 0.185 * 1.2
    ctx = cell_context(speed)
    per_metre = 300 / (135.0 * speed)
    totals = np.zeros(2)
    for seed in range(4):
        belt = random_belt(np.random.default_rng(100 + seed), int(per_metre * 12), 12.0, speed)
        timed = simulate(make_planner("rollout"), belt, ctx).profit
        path = simulate(make_planner("rollout", episode_starts=0), belt, ctx).profit
        nearest = simulate(make_planner("proximity"), belt, ctx).profit
        assert timed > nearest, (seed, timed, nearest)
        totals += (timed, path)
    assert totals[0] > totals[1], totals


def test_episode_settings_are_validated():
    with pytest.raises(PlannerInputError, match="episode_steps"):
        RolloutConfig(episode_steps=-1)
    with pytest.raises(PlannerInputError, match="episode_starts"):
        RolloutConfig(episode_starts=1.5)
