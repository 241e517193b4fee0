"""Training the `learned` pick-order policy on `sortsim/PickOrder-v0` (cross-entropy method).

The policy (`planner.decision.managers.learned.SlotPolicy`) is a linear scorer of the K most urgent
candidates. Its parameters are searched by the cross-entropy method: each iteration draws a
population of parameter vectors from a Gaussian, scores each by its mean profit over the same
training belts, and refits the Gaussian to the best fifth. The search starts at FIFO (all weight
on the time left in the window), so it can only keep or improve on it on the training belts.
Everything is seeded: the same seed gives the same weights, byte for byte. Training belts use
seeds from `TRAIN_SEED_BASE` up, disjoint from the evaluation belts (seeds 0-1999 of
`planner.decision.evaluation`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.decision.managers.learned import TERMS, SlotPolicy
from sim.envs.pick_order import PickOrderEnv

TRAIN_SEED_BASE = 1_000_000
"""First seed of the training belts."""
BUSY_BELTS: dict[str, Any] = {"items": (8, 12), "rate": (2.0, 8.0)}
"""The planner-level evaluation's busy belts: 8-12 items arriving at 2-8 items/s."""


@dataclass(frozen=True)
class TrainingConfig:
    """Settings of one training run.

    Attributes:
        seed: Seed of the search (population draws).
        iterations: Cross-entropy iterations.
        population: Parameter vectors scored per iteration.
        belts: Training belts each vector is scored on (the same belts for all of them).
        elite_fraction: Share of the population the Gaussian is refitted to.
        k_slots: Candidates the policy scores.
    """

    seed: int = 0
    iterations: int = 15
    population: int = 24
    belts: int = 32
    elite_fraction: float = 0.2
    k_slots: int = 8


def fifo_start() -> np.ndarray:
    """Parameters of FIFO: the candidate with the least time left first, never wait."""
    v = np.zeros(len(TERMS) + 1)
    v[TERMS.index("time_left_s")] = -1.0
    v[-1] = -1e3
    return v


def mean_profit(policy: SlotPolicy, env: PickOrderEnv, seeds) -> float:
    """Mean profit [EUR] of `policy` over the belts of `seeds`."""
    total = 0.0
    for seed in seeds:
        obs, info = env.reset(seed=int(seed))
        done = False
        while not done:
            obs, _, done, _, info = env.step(policy.act(obs, info["action_mask"]))
        total += info["profit_eur"]
    return total / len(seeds)


def train(
    config: TrainingConfig, progress: Callable[[int, float, float], None] | None = None
) -> tuple[SlotPolicy, dict]:
    """Search the policy's parameters; returns it and a summary (scores, time)."""
    rng = np.random.default_rng(config.seed)
    env = PickOrderEnv(k_slots=config.k_slots, **BUSY_BELTS)
    seeds = range(TRAIN_SEED_BASE, TRAIN_SEED_BASE + config.belts)
    mean = fifo_start()
    std = np.full_like(mean, 1.0)
    std[-1] = 1.0
    mean[-1] = -5.0  # start never waiting, but near enough for the search to try it
    n_elite = max(2, int(round(config.elite_fraction * config.population)))
    fifo_score = mean_profit(SlotPolicy.from_vector(fifo_start(), config.k_slots), env, seeds)
    best_vec, best_score = (
        mean.copy(),
        mean_profit(SlotPolicy.from_vector(mean, config.k_slots), env, seeds),
    )
    t0 = time.process_time()
    for it in range(config.iterations):
        samples = mean + std * rng.standard_normal((config.population, mean.size))
        scores = np.array(
            [mean_profit(SlotPolicy.from_vector(s, config.k_slots), env, seeds) for s in samples]
        )
        order = np.argsort(-scores, kind="stable")
        elite = samples[order[:n_elite]]
        mean, std = elite.mean(axis=0), elite.std(axis=0) + 0.02
        if scores[order[0]] > best_score:
            best_vec, best_score = samples[order[0]].copy(), float(scores[order[0]])
        if progress is not None:
            progress(it + 1, float(scores[order[0]]), best_score)
    policy = SlotPolicy.from_vector(best_vec, config.k_slots)
    summary = {
        "train_profit_eur": best_score,
        "fifo_train_profit_eur": fifo_score,
        "cpu_s": time.process_time() - t0,
        "belts": config.belts,
        "episodes": config.iterations * config.population * config.belts,
    }
    return policy, summary
