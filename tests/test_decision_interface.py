"""Decision interface: validation, expected value, registry, the cycle-time protocol."""

from __future__ import annotations

import pytest

from planner.decision.interface import CycleTimeEstimator, DecisionContext, RobotState, TrackedItem
from planner.decision.managers.qlearning import QLearningConfig
from planner.decision.registry import PLANNERS, make_planner
from planner.errors import PlannerInputError
from planner.motion.cycle_model import CycleTimeModel
from planner.motion.reach_window import ReachWindow
from planner.motion.straight_line_timing import StraightLineCycleModel
from sim.episode.decision_view import cell_context


def _context(**kw):
    base = dict(belt_speed=0.185, cycle_model=CycleTimeModel(), window=ReachWindow.disc())
    base.update(kw)
    return DecisionContext(**base)


def test_both_cycle_models_satisfy_the_protocol():
    assert isinstance(CycleTimeModel(), CycleTimeEstimator)
    assert isinstance(StraightLineCycleModel(), CycleTimeEstimator)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        (dict(values=(0.22, -0.25, 0.27)), "values"),
        (dict(values=()), "values"),
        (dict(values=(0.22, 0.25)), "bins"),  # two materials, three bins
        (dict(belt_speed=-0.1), "belt_speed"),
        (dict(bins=((0, 0, 0), (1, 1, 1))), "bins"),
        (dict(cycle_model=object()), "cycle_model"),
    ],
)
def test_context_refuses_bad_input(kwargs, field):
    with pytest.raises(PlannerInputError) as err:
        _context(**kwargs)
    assert err.value.field == field
    assert "allowed" in str(err.value)


@pytest.mark.parametrize(
    ("kwargs", "field", "allowed"),
    [
        (dict(gamma=1.0), "gamma", "[0, 1)"),
        (dict(gamma=-0.1), "gamma", "[0, 1)"),
        (dict(iterations=0), "iterations", ">= 1"),
        (dict(batch_rows=0), "batch_rows", ">= 1"),
        (dict(objective="v*d"), "objective", "v/d | d=1 | v=1"),
        (dict(row_period_s=0.0), "row_period_s", "> 0"),
        (dict(seed=-1), "seed", ">= 0"),
        (dict(seed=1.5), "seed", ">= 0"),
        (dict(q_init=-0.1), "q_init", ">= 0"),
    ],
)
def test_qlearning_config_refuses_bad_input(kwargs, field, allowed):
    with pytest.raises(PlannerInputError) as err:
        QLearningConfig(**kwargs)
    assert err.value.field == field
    assert allowed in err.value.allowed


def test_registry_builds_every_planner_and_refuses_unknown_names_and_options():
    for name in PLANNERS:
        assert make_planner(name).name == name
    with pytest.raises(PlannerInputError) as err:
        make_planner("randomly")
    assert err.value.allowed == (
        "qlearning | rollout | lookahead | learned | proximity | fifo | greedy | random | "
        "seen_best | best_order | module:Class "
        "(a class with choose() and reset())"
    )
    with pytest.raises(PlannerInputError) as err:
        make_planner("qlearning", alpha=0.5)
    assert "gamma" in err.value.allowed and "alpha" in err.value.field
    with pytest.raises(PlannerInputError):
        make_planner("proximity", gamma=0.9)
    with pytest.raises(PlannerInputError):
        make_planner("seen_best", max_items=0)
    assert make_planner("qlearning", gamma=0.5, objective="d=1").config.gamma == 0.5
    assert make_planner("qlearning", seed=7).config.seed == 7
    assert make_planner("rollout", gamma=0.5, episode_starts=0).config.episode_starts == 0
    assert make_planner("lookahead", horizon=6).config.horizon == 6
    with pytest.raises(PlannerInputError) as err:
        make_planner("rollout", seed=1)  # nothing random in the rollout
    assert "episode_starts" in err.value.allowed
    with pytest.raises(PlannerInputError):
        make_planner("lookahead", time_budget_s=0.0)


def test_tracked_item_validation_and_bin_class():
    with pytest.raises(PlannerInputError):
        TrackedItem(1, 0.0, 0.0, (0.5, 0.5, 0.5, 0.0))
    with pytest.raises(PlannerInputError):
        TrackedItem(1, 0.0, 0.0, (1.0,))  # void alone: no material
    with pytest.raises(PlannerInputError):
        RobotState((0.0, 0.0), 0.0)
    # Void most probable overall, but the bin is the most probable material's.
    item = TrackedItem(1, 0.0, 0.0, (0.55, 0.1, 0.3, 0.05))
    assert item.bin_class == 3
    assert TrackedItem.certain(2, 0.0, 0.0, 4).class_probs == (0.0, 0.0, 0.0, 1.0)


def test_a_moved_tracked_item_equals_one_made_anew_and_refuses_bad_positions():
    item = TrackedItem(1, 0.2, -0.1, (0.55, 0.1, 0.3, 0.05))
    moved = item.at(-0.4, 0.25)
    anew = TrackedItem(1, -0.4, 0.25, (0.55, 0.1, 0.3, 0.05))
    assert moved == anew and vars(moved) == vars(anew) and moved.bin_class == 3
    assert (item.x, item.y) == (0.2, -0.1)  # the original stays where it was
    for x, y in ((float("nan"), 0.0), (0.0, float("inf"))):
        with pytest.raises(PlannerInputError, match="x, y"):
            item.at(x, y)


def test_expected_value_ranks_a_confident_aluminium_above_an_uncertain_one():
    ctx = _context()
    confident = TrackedItem(1, 0.0, 0.1, (0.0, 0.02, 0.03, 0.95))
    uncertain = TrackedItem(2, 0.0, 0.1, (0.0, 0.3, 0.25, 0.45))
    paper = TrackedItem.certain(3, 0.0, 0.1, 2)
    assert ctx.expected_value(confident) == pytest.approx(0.95 * 0.27)
    assert ctx.expected_value(uncertain) == pytest.approx(0.45 * 0.27)
    assert ctx.expected_value(confident) > ctx.expected_value(paper) > ctx.expected_value(uncertain)
    # Every value-aware planner, at equal distance, prefers the confident one.
    robot = RobotState((0.0, 0.0, 0.06), 0.0)
    # (The thesis's Q-learning adds the q of random continuations; myopic and on value only,
    # its q is the expected value.)
    for name, kw in [
        ("qlearning", dict(gamma=0.0, objective="d=1")),
        ("rollout", {}),
        ("lookahead", {}),
        ("greedy", {}),
        ("seen_best", {}),
    ]:
        items = [uncertain, TrackedItem(1, 0.0, -0.1, confident.class_probs)]
        assert make_planner(name, **kw).choose(items, robot, ctx).item_id == 1, name


def test_cell_context_reads_bins_from_the_model():
    ctx = cell_context(0.185)
    paper, plastic, aluminium = ctx.bins
    assert paper[1] < -0.4 and plastic[1] > 0.4 and aluminium[1] > 0.4
    assert plastic[0] < 0.0 < aluminium[0]
    assert ctx.window.contains(0.0, 0.0) and not ctx.window.contains(0.9, 0.0)


def test_the_episode_configures_qlearning_and_rollout_from_its_qlearning_section():
    from sim import config
    from sim.episode.loop import make_decision_manager

    base = config.load(None, seed=5, planner="qlearning", observation_period_s=0.25)
    base = base.replace(qlearning=config.QLearning(gamma=0.8, objective="value_only"))
    q = make_decision_manager(base)
    assert (q.name, q.config.seed, q.config.gamma, q.config.objective) == (
        "qlearning",
        5,
        0.8,
        "d=1",
    )
    assert q.config.row_period_s == 0.25 and q.config.iterations == 50
    r = make_decision_manager(base.replace(planner="rollout"))
    assert (r.name, r.config.gamma, r.config.objective) == ("rollout", 0.8, "d=1")
    assert make_decision_manager(base.replace(planner="lookahead")).name == "lookahead"
