"""The Gymnasium environments: API checks, determinism by seed, masks, rewards that add up."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim.envs  # noqa: F401  (registers the ids)
from planner.decision.slot_features import N_FEATURES

SMALL_CELL = {"items": 12, "duration_s": 8.0}


def _rollout(env, seed: int, policy) -> tuple[list[np.ndarray], list[float], dict]:
    obs, info = env.reset(seed=seed)
    seen, rewards = [obs], []
    for _ in range(10_000):
        obs, reward, terminated, truncated, info = env.step(policy(info["action_mask"]))
        seen.append(obs)
        rewards.append(reward)
        if terminated or truncated:
            break
    return seen, rewards, info


def _first_slot(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])


def test_pick_order_passes_the_checker():
    check_env(gym.make("sortsim/PickOrder-v0").unwrapped)


def test_sorting_cell_passes_the_checker():
    env = gym.make("sortsim/SortingCell-v0", **SMALL_CELL).unwrapped
    try:
        check_env(env)
    finally:
        env.close()


def test_pick_order_is_deterministic_by_seed_and_rewards_add_up_to_the_profit():
    env = gym.make("sortsim/PickOrder-v0").unwrapped
    a = _rollout(env, 7, _first_slot)
    b = _rollout(env, 7, _first_slot)
    assert len(a[0]) == len(b[0]) and all(
        np.array_equal(x, y) for x, y in zip(a[0], b[0], strict=True)
    )
    assert sum(a[1]) == pytest.approx(a[2]["profit_eur"], abs=1e-9)
    assert a[2]["picked"] > 0
    other = _rollout(env, 8, _first_slot)
    assert not np.array_equal(a[0][0], other[0][0])


def test_the_mask_marks_exactly_the_filled_slots_and_wait():
    env = gym.make("sortsim/PickOrder-v0", k_slots=4).unwrapped
    obs, info = env.reset(seed=3)
    slots = obs.reshape(4, N_FEATURES)
    mask = info["action_mask"]
    assert mask.shape == (5,) and mask[4]
    assert np.array_equal(mask[:4], slots[:, 0] == 1.0)
    # Slots come most urgent first: time left in the window never decreases along them.
    left = slots[slots[:, 0] == 1.0, 7]
    assert np.all(np.diff(left) >= -1e-6)


def test_a_masked_out_action_waits():
    env = gym.make("sortsim/PickOrder-v0", k_slots=64, items=(1, 1)).unwrapped
    obs, info = env.reset(seed=0)
    t0 = info["time_s"]
    _, reward, _, _, info = env.step(63)  # an empty slot: nothing is picked, time goes on
    assert reward == 0.0 and info["picked"] == 0 and info["time_s"] > t0


def test_sorting_cell_rewards_add_up_to_the_episode_profit():
    env = gym.make("sortsim/SortingCell-v0", **SMALL_CELL).unwrapped
    try:
        seen, rewards, info = _rollout(env, 2, _first_slot)
        assert info["picked"] >= 10  # 12 items on a light belt
        assert sum(rewards) == pytest.approx(info["profit_eur"], abs=1e-9)
        again, rewards2, _ = _rollout(env, 2, _first_slot)
        assert rewards2 == rewards
    finally:
        env.close()
