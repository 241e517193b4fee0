"""The learned pick-order policy: loads, refuses bad files, trains deterministically, and beats
FIFO on belts it was not trained on."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner.decision.evaluation import short_belt
from planner.decision.kinematic_belt import simulate
from planner.decision.managers.fifo import FifoPlanner
from planner.decision.managers.learned import POLICY_FILE, TERMS, LearnedPlanner, SlotPolicy
from planner.errors import PlannerInputError
from sim.episode.decision_view import cell_context
from sim.evaluation.policy_training import TRAIN_SEED_BASE, TrainingConfig, fifo_start, train


def test_the_shipped_policy_loads_and_round_trips(tmp_path):
    policy = SlotPolicy.load(POLICY_FILE)
    assert len(policy.weights) == len(TERMS)
    path = tmp_path / "p.json"
    policy.save(path)
    assert SlotPolicy.load(path) == policy


@pytest.mark.parametrize(
    "text",
    ["not json", "{}", json.dumps({"terms": ["x"], "weights": [1], "wait_score": 0, "k_slots": 8})],
)
def test_a_broken_policy_file_is_refused(tmp_path, text):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(PlannerInputError, match="policy"):
        SlotPolicy.load(path)


def test_a_nan_weight_is_refused():
    with pytest.raises(PlannerInputError, match="weights"):
        SlotPolicy((float("nan"),) * len(TERMS), 0.0)


def test_the_fifo_start_decides_as_fifo():
    start = LearnedPlanner(SlotPolicy.from_vector(fifo_start()))
    for seed in range(10):
        belt = short_belt(seed)
        ctx = cell_context(belt.speed)
        a, b = simulate(start, belt, ctx), simulate(FifoPlanner(), belt, ctx)
        assert [p.item_id for p in a.picks] == [p.item_id for p in b.picks]


def test_training_is_deterministic_by_seed():
    config = TrainingConfig(seed=3, iterations=2, population=6, belts=4)
    a, _ = train(config)
    b, _ = train(config)
    assert np.array_equal(a.vector(), b.vector())


def test_the_shipped_policy_beats_fifo_on_held_out_belts():
    # Evaluation belts are seeds 0.., training belts start at TRAIN_SEED_BASE.
    assert TRAIN_SEED_BASE > 10_000
    learned, fifo = LearnedPlanner(), FifoPlanner()
    gain = []
    for seed in range(60):
        belt = short_belt(seed)
        ctx = cell_context(belt.speed)
        gain.append(simulate(learned, belt, ctx).profit - simulate(fifo, belt, ctx).profit)
    assert sum(gain) > 0.0 and np.mean(np.array(gain) > 0) > np.mean(np.array(gain) < 0)
