"""The thesis's "random picker" (`random`): only items the cup can meet now, each as likely,
deterministic by seed; and `sortsim run --planner random` on a busy belt."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from planner.decision.candidates import candidates
from planner.decision.interface import RobotState, TrackedItem
from planner.decision.kinematic_belt import random_belt, simulate
from planner.decision.registry import make_planner
from planner.errors import PlannerInputError
from sim import config as episode_config
from sim.cli.main import main
from sim.episode.decision_view import cell_context
from sim.episode.runner import run_episode
from sim.results import outputs

V = 0.185
PAPER_BIN = (0.0, -0.51, 0.06)


def _scattered_items(rng: np.random.Generator, n: int) -> list[TrackedItem]:
    """Items upstream of, inside and past the window, a fifth of them void (worth nothing)."""
    xs = rng.uniform(-1.2, 1.0, n)
    ys = rng.uniform(-0.35, 0.35, n)
    classes = rng.choice([1, 2, 3, 4], size=n, p=[0.2, 0.3, 0.25, 0.25])
    return [TrackedItem.certain(i, xs[i], ys[i], int(classes[i])) for i in range(n)]


def test_it_picks_only_items_the_cup_can_meet_now():
    """On 300 scattered belts, every pick is one of the candidates the cup meets without
    waiting (never an item upstream of the window, past it, or void), and None when there is
    none."""
    ctx = cell_context(V)
    rng = np.random.default_rng(7)
    nones = 0
    for seed in range(300):
        items = _scattered_items(rng, int(rng.integers(1, 12)))
        robot = RobotState(PAPER_BIN, 0.0)
        reachable = {
            c.item.item_id
            for c in candidates(items, robot, ctx, immediate_only=True, with_place=False)
        }
        choice = make_planner("random", seed=seed).choose(items, robot, ctx)
        if not reachable:
            assert choice is None
            nones += 1
        else:
            assert choice is not None and choice.item_id in reachable, seed
    assert 0 < nones < 300  # both cases were met


def test_the_draw_is_uniform_over_the_reachable_items():
    """Four items in the window: over 400 seeds each is drawn first 100 +- 30 times (the
    binomial's standard deviation is 8.7)."""
    ctx = cell_context(V)
    items = [TrackedItem.certain(i, -0.1 + 0.05 * i, 0.1 * (i - 2), 2 + i % 3) for i in range(4)]
    robot = RobotState(PAPER_BIN, 0.0)
    assert len(candidates(items, robot, ctx, immediate_only=True, with_place=False)) == 4
    firsts = Counter(
        make_planner("random", seed=s).choose(items, robot, ctx).item_id for s in range(400)
    )
    assert sorted(firsts) == [0, 1, 2, 3]
    assert all(70 <= n <= 130 for n in firsts.values()), firsts


def test_the_same_seed_picks_the_same_order_and_another_seed_another():
    ctx = cell_context(V)
    belt = random_belt(np.random.default_rng(3), 30, 2.0, V)

    def order(seed, stream=0):
        result = simulate(make_planner("random", seed=seed, stream=stream), belt, ctx, PAPER_BIN)
        return [p.item_id for p in result.picks]

    assert order(5) == order(5)
    assert order(5) != order(6)
    assert order(5, stream=1) != order(5)  # a line's second robot draws its own sequence
    planner = make_planner("random", seed=5)
    first = simulate(planner, belt, ctx, PAPER_BIN)
    assert [p.item_id for p in simulate(planner, belt, ctx, PAPER_BIN).picks] == [
        p.item_id for p in first.picks
    ]  # reset() starts the draws again


@pytest.mark.parametrize("bad", [-1, 1.5, True, "0"])
def test_a_bad_seed_is_refused(bad):
    with pytest.raises(PlannerInputError) as err:
        make_planner("random", seed=bad)
    assert err.value.field == "seed" and ">= 0" in err.value.allowed


BUSY = {"items": 16, "duration_s": 3.0, "perception": "truth", "planner": "random", "seed": 9}
"""A belt busier than the cell's cycle: several items in reach at each decision."""


def test_sortsim_run_random_is_deterministic_by_seed(tmp_path):
    """`sortsim run --planner random` twice with one seed: the same picks.csv, byte for byte;
    the same flow with the draws of another seed: the items picked in another order."""
    args = ["run", "--planner", "random", "--perception", "truth", "--items", "16"]
    args += ["--duration", "3", "--seed", "9", "--quiet"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    picks = (tmp_path / "a" / "picks.csv").read_bytes()
    assert picks == (tmp_path / "b" / "picks.csv").read_bytes()
    rows = outputs.read_rows(tmp_path / "a" / "picks.csv")
    assert len(rows) >= 8 and outputs.read_rows(tmp_path / "a" / "episodes.csv")[0]["planner"] == (
        "random"
    )
    config = episode_config.load(None, **BUSY)
    other = run_episode(config, planner=make_planner("random", seed=10))
    ours = [r["item_id"] for r in rows]
    theirs = [str(p["item_id"]) for p in other.pick_rows]
    assert ours != theirs
    assert other.episode_row["entered"] == int(
        outputs.read_rows(tmp_path / "a" / "episodes.csv")[0]["entered"]
    )


def test_the_episode_seeds_it_and_each_robot_of_a_line_draws_its_own_stream():
    from sim.episode.loop import make_decision_manager

    config = episode_config.load(None, **BUSY)
    first, second = make_decision_manager(config), make_decision_manager(config, robot=1)
    assert (first.name, first.seed, first.stream) == ("random", 9, 0)
    assert (second.seed, second.stream) == (9, 1)
