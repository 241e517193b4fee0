"""The thesis's Q-learning as written (3.4.1, eq. 3.3 and 3.5, the annex's random actions, the
stopping rule, the 20 x 27 batch grid) against hand computations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner.decision.batch_grid import GRID_COLUMNS, column_centre, grid_column
from planner.decision.interface import RobotState, TrackedItem
from planner.decision.kinematic_belt import random_belt, simulate
from planner.decision.managers.qlearning import (
    QLearningConfig,
    QLearningPlanner,
    assign_cells,
    learn,
    rewards_from,
)
from planner.decision.registry import make_planner
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
CELLS = [(0, 3), (4, 10), (9, 20)]
SHAPE = (20, GRID_COLUMNS)


class Scripted:
    """Stands in for numpy's Generator: zeros for the initial q, then one given list of
    uniforms per episode (step i of an episode takes item floor(u_i x items left))."""

    def __init__(self, episodes):
        self.episodes = [list(u) for u in episodes]
        self.initial = True

    def random(self, size):
        if self.initial:
            self.initial = False
            return np.zeros(size)
        u = self.episodes.pop(0)
        assert len(u) == size
        return np.array(u)


def _learn(episodes, iterations, gamma=0.9, rewards=REWARDS):
    return learn(rewards, NEXT, CELLS, SHAPE, gamma, iterations, Scripted(episodes))


def test_three_episodes_by_hand():
    # Episode 1 draws items 0 then 1: q0 = 0.5 + 0.9 max(q1, q2) = 0.5 (both still 0), robot at
    # the paper bin, where the rest is worth 0.6 + 0.2 >= 0.5 (the most precious reward at the
    # start): go on; q1 = 0.6 + 0.9 q2 = 0.6; robot at the plastic bin, the rest is 0.35 < 0.5:
    # the stopping rule ends the episode.
    learned = _learn([[0.0, 0.0, 0.0]], iterations=1)
    assert [learned.q_of(k) for k in range(3)] == pytest.approx([0.5, 0.6, 0.0], abs=1e-12)
    assert (learned.episodes, learned.steps) == (1, 2)
    # Episode 2 draws items 2, 0, 1: q2 = 0.30 + 0.9 * 0.6 = 0.84 (from the start); from the
    # aluminium bin (0.20 + 0.45 >= 0.5) q0 = 0.20 + 0.9 q1 = 0.74; from the paper bin (0.6 >=
    # 0.5) q1 = 0.60 + 0.9 * 0 = 0.6, nothing left.
    # Episode 3 draws item 1: q1 = 0.40 + 0.9 max(q0, q2) = 0.40 + 0.9 * 0.84 = 1.156; from the
    # plastic bin the rest is 0.10 + 0.35 < 0.5: stop.
    episodes = [[0.0, 0.0, 0.0], [0.99, 0.0, 0.0], [0.5, 0.0, 0.0]]
    learned = _learn(episodes, iterations=3)
    assert [learned.q_of(k) for k in range(3)] == pytest.approx([0.74, 1.156, 0.84], abs=1e-12)
    assert (learned.episodes, learned.steps) == (3, 6)
    assert learned.q.shape == (20, 27)
    assert learned.q[4, 10] == pytest.approx(1.156)  # the matrix holds q at the items' cells
    assert np.count_nonzero(learned.q) == 3


def test_learning_stops_once_an_episode_changes_nothing():
    # Episode 4 repeats episode 3: q1 = 0.40 + 0.9 * 0.84 again, nothing changes: the learning
    # stops after 4 of the 50 episodes.
    episodes = [[0.0, 0.0, 0.0], [0.99, 0.0, 0.0], [0.5, 0.0, 0.0], [0.5, 0.0, 0.0]]
    learned = _learn(episodes, iterations=50)
    assert learned.episodes == 4
    assert learned.q_of(1) == pytest.approx(1.156)


def test_the_stopping_rule_fires_below_the_most_precious_reward_not_at_it():
    rewards = REWARDS.copy()
    rewards[1] = [0.0, 0.3, 0.2]  # from the paper bin the rest sums to exactly 0.5
    rewards[2, 2] = 0.5  # and from the plastic bin too
    assert _learn([[0.0, 0.0, 0.0]], 1, rewards=rewards).steps == 3
    rewards[1, 2] = 0.2 - 1e-9  # now just below: one step only
    assert _learn([[0.0, 0.0, 0.0]], 1, rewards=rewards).steps == 1


def test_gamma_zero_is_myopic():
    # q is the reward from where the robot was when the item was last taken.
    episodes = [[0.0, 0.0, 0.0], [0.99, 0.0, 0.0]]
    learned = _learn(episodes, iterations=2, gamma=0.0)
    assert [learned.q_of(k) for k in range(3)] == pytest.approx([0.20, 0.60, 0.30])


def test_the_random_initial_q_and_actions_come_from_the_seed():
    a = learn(REWARDS, NEXT, CELLS, SHAPE, 0.9, 50, np.random.default_rng(5))
    b = learn(REWARDS, NEXT, CELLS, SHAPE, 0.9, 50, np.random.default_rng(5))
    assert np.array_equal(a.q, b.q) and a.episodes == b.episodes
    c = learn(REWARDS, NEXT, CELLS, SHAPE, 0.9, 50, np.random.default_rng(6))
    assert not np.array_equal(a.q, c.q)
    # The cells no item occupies keep their random initial q, below q_init x the top reward.
    empty = np.ones(SHAPE, dtype=bool)
    for r, col in CELLS:
        empty[r, col] = False
    assert np.all(a.q[empty] >= 0.0) and np.all(a.q[empty] < 0.01 * 0.6)
    assert np.count_nonzero(a.q[empty]) > 0


def test_rewards_are_value_over_robot_item_bin_distance():
    points = np.array([[0.1, 0.2], [-0.2, -0.25]])
    values = np.array([0.27, 0.22])
    bins = np.array([[0.21, 0.51], [0.0, -0.56]])
    starts = np.array([[0.0, 0.3], [0.0, -0.56], [-0.21, 0.51], [0.21, 0.51]])
    for objective in ("v/d", "d=1", "v=1"):
        w = rewards_from(points, values, bins, starts, objective)
        for s in range(4):
            for k in range(2):
                d = math.dist(starts[s], points[k]) + math.dist(points[k], bins[k])
                want = {"v/d": values[k] / d, "d=1": values[k], "v=1": 1 / d}[objective]
                assert w[s, k] == pytest.approx(want, rel=1e-12)


def test_items_take_distinct_cells():
    assert assign_cells([(3, 5), (3, 5), (3, 5), (0, 1)], 20) == [(3, 5), (3, 4), (3, 6), (0, 1)]
    assert assign_cells([(0, 1), (0, 1)], 1) == [(0, 1), (0, 2)]
    assert grid_column(column_centre(7)) == 7


def test_the_planner_learns_on_the_grid_and_picks_the_max_q():
    ctx = cell_context(0.185)
    cfg = QLearningConfig(seed=3)
    pitch = 0.185 * cfg.row_period_s
    robot = RobotState(ctx.bins[0], 0.0)
    items = [
        TrackedItem.certain(1, 0.0, -0.30, 2),  # the first item seen: row 0
        TrackedItem.certain(2, -2.5 * pitch, 0.25, 4),  # row 2
        TrackedItem.certain(3, -4.2 * pitch, 0.0, 3),  # row 4
    ]
    planner = QLearningPlanner(cfg)
    choice = planner.choose(items, robot, ctx)
    learned = planner._learned
    # Items by urgency (exit time); rows counted from the first item, columns 0..26 (the
    # thesis's 1..27), the belt's 25 in 1..25.
    assert learned.cells == ((0, 4), (2, 21), (4, 13))
    assert learned.q.shape == (20, 27)
    q = {i: learned.q_of(k) for k, i in enumerate([1, 2, 3])}
    assert choice.item_id == max(q, key=q.get)
    assert "max q" in choice.reason and "episodes" in choice.reason
    # The same seed, the same choice; the learning is not repeated while no new item arrives.
    planner.reset()
    again = planner.choose(items, robot, ctx)
    assert again.item_id == choice.item_id
    first = planner._learned
    later = [TrackedItem(i.item_id, i.x + 0.185 * 0.5, i.y, i.class_probs) for i in items]
    planner.choose(later[1:], RobotState(ctx.bins[2], 0.5), ctx)
    assert planner._learned is first


def test_an_earlier_batch_keeps_priority_over_a_better_later_one():
    ctx = cell_context(0.185)
    cfg = QLearningConfig(batch_rows=2)  # batches of 2 rows = 0.185 m so both are in reach
    pitch = 0.185 * cfg.row_period_s
    robot = RobotState((0.2, 0.51, 0.06), 0.0)
    downstream_paper = TrackedItem.certain(1, -0.5 * pitch, -0.3, 2)  # batch 0, far from robot
    upstream_alu = TrackedItem.certain(2, -2.5 * pitch, 0.35, 4)  # batch 1, next to the robot
    for seed in range(5):
        planner = QLearningPlanner(QLearningConfig(batch_rows=2, seed=seed))
        assert planner.choose([upstream_alu, downstream_paper], robot, ctx).item_id == 1


def test_runs_are_deterministic_by_seed():
    ctx = cell_context(0.185)
    belt = random_belt(np.random.default_rng(8), 40, 3.0, 0.185)
    a = simulate(make_planner("qlearning", seed=1), belt, ctx)
    b = simulate(make_planner("qlearning", seed=1), belt, ctx)
    c = simulate(make_planner("qlearning", seed=2), belt, ctx)
    assert a.picks == b.picks
    assert [p.item_id for p in a.picks] != [p.item_id for p in c.picks]
