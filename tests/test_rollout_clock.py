"""The clock of the Q-learning manager's timed episodes (`rollout_episodes.episode_q`), by hand.

A stub cycle-time model makes every pick take 0.5 s (decision to contact) and every place 1.0 s
(contact to the end of the release), on a belt at 0.1 m/s and a square window
-0.5 <= x <= 0.5 (|y| <= 0.45). The robot's clock after each move is then simple arithmetic:
a move ends at meet + 1.0, the next item is met 0.5 s later (or when it enters the window, if
it is still upstream), and an item whose meeting point lies past x = 0.5 is lost. The episodes
below were worked out on paper; their q (eq. 3.5, gamma 0.9) and lengths are compared with the
code's, and the stub records where and when each move was timed from.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner.decision.candidates import Candidate
from planner.decision.interface import DEFAULT_BINS, DecisionContext, TrackedItem
from planner.decision.managers.rollout_episodes import episode_q, weight
from planner.motion.reach_window import ReachWindow

PICK_S = 0.5
PLACE_S = 1.0
SPEED = 0.1
GAMMA = 0.9
PAPER_BIN, PLASTIC_BIN, ALU_BIN = ((b[0], b[1]) for b in DEFAULT_BINS)


class StubCycleModel:
    """Fixed move times; records the calls (start or pick point, and the item or bin)."""

    def __init__(self):
        self.picks: list[tuple[tuple[float, ...], tuple[float, float]]] = []
        self.places: list[tuple[tuple[float, ...], tuple[float, ...]]] = []

    def time_to_pick(self, start_xyz, item_xy, belt_speed: float) -> float:
        """0.5 s from anywhere."""
        self.picks.append((tuple(start_xyz), tuple(item_xy)))
        return PICK_S

    def time_to_place(self, pick_xyz, bin_xyz) -> float:
        """1.0 s to any bin."""
        self.places.append((tuple(pick_xyz), tuple(bin_xyz)))
        return PLACE_S


def square_context(model: StubCycleModel) -> DecisionContext:
    """Belt at 0.1 m/s, window -0.5..0.5 in x for |y| <= 0.45, the default bins."""
    window = ReachWindow(
        np.array([-0.45, 0.45]), np.array([-0.5, -0.5]), np.array([0.5, 0.5]), pick_z=0.02
    )
    return DecisionContext(SPEED, model, window)


def first_pick(end_time: float = 1.5) -> Candidate:
    """A first pick already timed: met at 0.5 s, released over the paper bin at 1.5 s."""
    item = TrackedItem.certain(0, 0.0, -0.2, 2)
    return Candidate(
        item=item,
        expected_value=0.22,
        bin_class=2,
        meet_time=0.5,
        meet_xy=(0.05, -0.2),
        end_time=end_time,
        exit_time=4.5,
        start_time=0.0,
    )


def w(value: float, start_xy, meet_xy, bin_xy) -> float:
    """Eq. 3.3 written out: value over the belt-plane distance start -> item -> bin."""
    return value / (math.dist(start_xy, meet_xy) + math.dist(meet_xy, bin_xy))


# (id, x at t0, y, expected value, bin class)
ITEM_A = (1, -0.2, 0.0, 10.0, 4)  # valuable, taken first after the first pick
ITEM_B = (2, 0.22, 0.1, 1.0, 3)  # near the window's end: lost if the clock counts the place
ITEM_C = (3, -1.0, -0.1, 1.0, 2)  # upstream: the robot waits for it at the window's entry


def test_three_move_episode_by_hand():
    model = StubCycleModel()
    context = square_context(model)
    q, moves = episode_q(
        first_pick(), 1.0, [ITEM_A, ITEM_B, ITEM_C], 0.0, context, GAMMA, "v/d", steps=8
    )
    # Move 2 starts at 1.5 s over the paper bin. A is at -0.2 + 0.15 = -0.05, met 0.5 s
    # later at x = 0.0 (t = 2.0); the place ends at 2.0 + 1.0 = 3.0 over the aluminium bin.
    w_a = w(10.0, PAPER_BIN, (0.0, 0.0), ALU_BIN)
    # Move 3 starts at 3.0: B is at 0.22 + 0.3 = 0.52, past the window's end: lost. C is at
    # -1.0 + 0.3 = -0.7; 0.5 s later it would be at -0.65, still upstream: the robot waits at
    # the entry x = -0.5, which C reaches at 3.0 + 0.2 / 0.1 = 5.0; released at 6.0.
    w_c = w(1.0, ALU_BIN, (-0.5, -0.1), PAPER_BIN)
    # Move 4 starts at 6.0: nothing is left (B lost, A and C taken).
    assert moves == 3
    assert q == pytest.approx(1.0 + GAMMA * (w_a + GAMMA * w_c), rel=1e-12)
    # Where each timing started from: the paper bin at 1.5 s (A, B, C), then the aluminium bin
    # at 3.0 s (C only: B is past the window before the pick is even timed).
    starts = [s[:2] for s, _ in model.picks]
    assert starts == [PAPER_BIN] * 3 + [ALU_BIN]
    items_at = [xy for _, xy in model.picks]
    np.testing.assert_allclose(
        items_at, [(-0.05, 0.0), (0.37, 0.1), (-0.85, -0.1), (-0.7, -0.1)], atol=1e-12
    )
    # A place is timed for each item that becomes the move's best so far: A at move 2 (B and C
    # weigh less: worth 1 against 10), C at move 3.
    assert [b[:2] for _, b in model.places] == [ALU_BIN, PAPER_BIN]
    met = [p[:2] for p, _ in model.places]
    np.testing.assert_allclose(met, [(0.0, 0.0), (-0.5, -0.1)], atol=1e-12)


def test_the_place_move_keeps_an_item_out_of_reach():
    # The same batch without C: after A's place (3.0 s) B is gone, so the episode ends at two
    # moves. A clock that forgot the place (2.0 s) would still find B at 0.42 and take it.
    model = StubCycleModel()
    q, moves = episode_q(
        first_pick(), 1.0, [ITEM_A, ITEM_B], 0.0, square_context(model), GAMMA, "v/d", 8
    )
    w_a = w(10.0, PAPER_BIN, (0.0, 0.0), ALU_BIN)
    assert moves == 2
    assert q == pytest.approx(1.0 + GAMMA * w_a, rel=1e-12)


def test_a_later_first_release_loses_the_next_item_too():
    # The first pick's release ending 1.5 s later (3.0 s): A is then at 0.1, met at 0.15 at
    # 3.5 s, placed by 4.5 s; B (0.52 at 3.0 s) is lost at once.
    model = StubCycleModel()
    q, moves = episode_q(
        first_pick(end_time=3.0), 2.0, [ITEM_A, ITEM_B], 0.0, square_context(model), GAMMA,
        "v/d", 8,
    )  # fmt: skip
    w_a = w(10.0, PAPER_BIN, (0.15, 0.0), ALU_BIN)
    assert moves == 2
    assert q == pytest.approx(2.0 + GAMMA * w_a, rel=1e-12)
    np.testing.assert_allclose([xy for _, xy in model.picks], [(0.1, 0.0)], atol=1e-12)


def test_a_chain_of_places_clocks_every_move():
    # Four plastic items one behind the other on y = 0, each worth the same: with 'd=1' every
    # reward is the value, ties go to the first in the list, so they are taken in order. Each
    # move after the first starts 1.5 s after the last (0.5 s pick + 1.0 s place) and times a
    # pick to every item left, at its place at that time: x0 + 0.1 t.
    x0 = [-0.3 - 0.1 * k for k in range(4)]
    items = [(10 + k, x0[k], 0.0, 1.0, 3) for k in range(4)]
    model = StubCycleModel()
    q, moves = episode_q(first_pick(), 1.0, items, 0.0, square_context(model), GAMMA, "d=1", 8)
    assert moves == 5  # the first pick and all four (met at x = -0.1, -0.05, 0.0, 0.05)
    assert q == pytest.approx(sum(GAMMA**k for k in range(5)), rel=1e-12)
    expected = []
    for move, t in enumerate((1.5, 3.0, 4.5, 6.0)):
        start = PAPER_BIN if move == 0 else PLASTIC_BIN
        expected += [(start, (x0[k] + SPEED * t, 0.0)) for k in range(move, 4)]
    got = [(s[:2], xy) for s, xy in model.picks]
    assert [s for s, _ in got] == [s for s, _ in expected]
    np.testing.assert_allclose([xy for _, xy in got], [xy for _, xy in expected], atol=1e-12)
    # The meeting points: 0.5 s after each move's start.
    met = [p[0] for p, _ in model.places]
    np.testing.assert_allclose(met, [-0.1, -0.05, 0.0, 0.05], atol=1e-12)


def test_weight_is_value_over_the_two_legs():
    assert weight(0.27, (0.0, 0.0), (0.3, 0.4), (0.3, 0.0), "v/d") == pytest.approx(0.27 / 0.9)
    assert weight(0.27, (0.0, 0.0), (0.3, 0.4), (0.3, 0.0), "d=1") == 0.27
    assert weight(0.27, (0.0, 0.0), (0.3, 0.4), (0.3, 0.0), "v=1") == pytest.approx(1 / 0.9)
