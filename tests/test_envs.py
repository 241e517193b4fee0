"""The Gymnasium environments: API checks (rendering included), determinism by seed, masks and
`action_masks()`, invalid actions refused by default, RGB frames, vector environments, rewards
that add up."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim.envs  # noqa: F401  (registers the ids)
from planner.decision.slot_features import N_FEATURES
from sim.envs.actions import InvalidAction
from sim.episode.overlay import overlay_of

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


# Gymnasium's checker steps `action_space.sample()`, which knows no mask: it checks the
# environments as they take a masked-out action as waiting. Its render check makes each one again
# with render_mode="rgb_array" and checks the frame.


def test_pick_order_passes_the_checker():
    check_env(gym.make("sortsim/PickOrder-v0", invalid_action="wait").unwrapped)


def test_sorting_cell_passes_the_checker():
    env = gym.make("sortsim/SortingCell-v0", invalid_action="wait", **SMALL_CELL).unwrapped
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


def test_a_masked_out_action_waits_when_asked_to():
    env = gym.make("sortsim/PickOrder-v0", k_slots=64, items=(1, 1), invalid_action="wait")
    obs, info = env.reset(seed=0)
    t0 = info["time_s"]
    _, reward, _, _, info = env.step(63)  # an empty slot: nothing is picked, time goes on
    assert reward == 0.0 and info["picked"] == 0 and info["time_s"] > t0
    _, reward, _, _, info = env.step(99)  # out of range: the same
    assert reward == 0.0 and info["picked"] == 0


@pytest.mark.parametrize("action", [63, 65, -1, 2.5, "1"])
def test_a_masked_out_or_out_of_range_action_raises_by_default(action):
    env = gym.make("sortsim/PickOrder-v0", k_slots=64, items=(1, 1)).unwrapped
    obs, info = env.reset(seed=0)
    assert info["action_mask"].sum() == 2  # one candidate and wait
    with pytest.raises(InvalidAction, match=r"action: allowed .*0\) or 64 to wait") as raised:
        env.step(action)
    assert isinstance(raised.value, ValueError)
    assert env.t == info["time_s"]  # refused before anything was stepped
    _, reward, _, _, after = env.step(np.int64(0))  # a NumPy integer is an action
    assert after["picked"] == 1


def test_an_unknown_invalid_action_setting_is_refused():
    with pytest.raises(ValueError, match="invalid_action"):
        gym.make("sortsim/PickOrder-v0", invalid_action="ignore")


def test_action_masks_is_the_infos_mask():
    env = gym.make("sortsim/PickOrder-v0")
    obs, info = env.reset(seed=1)
    for _ in range(20):
        mask = env.unwrapped.action_masks()
        assert mask.dtype == bool and np.array_equal(mask, info["action_mask"])
        assert env.get_wrapper_attr("action_masks")() is not mask  # a copy each call
        obs, _, terminated, _, info = env.step(_first_slot(mask))
        if terminated:
            break


def test_pick_order_renders_the_belt_from_above():
    env = gym.make("sortsim/PickOrder-v0", render_mode="rgb_array")
    assert env.metadata["render_fps"] > 0 and "rgb_array" in env.metadata["render_modes"]
    obs, info = env.reset(seed=3)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.shape == (520, 800, 3)
    # the candidates' white rings, the belt's grey and the paper's orange are there
    assert (frame == 255).all(axis=2).sum() > 100
    assert (np.abs(frame.astype(int) - (230, 170, 60)).sum(axis=2) < 10).sum() > 50
    env.step(_first_slot(info["action_mask"]))
    assert not np.array_equal(env.render(), frame)
    assert gym.make("sortsim/PickOrder-v0").unwrapped.render() is None  # no render mode


def test_a_vector_of_pick_order_environments_steps_with_masks():
    envs = gym.vector.SyncVectorEnv(
        [lambda: gym.make("sortsim/PickOrder-v0", k_slots=4) for _ in range(2)]
    )
    obs, infos = envs.reset(seed=[0, 1])
    assert obs.shape == (2, 4 * N_FEATURES)
    for _ in range(30):
        masks = np.stack(envs.call("action_masks"))
        obs, rewards, terminated, truncated, infos = envs.step(
            np.array([_first_slot(m) for m in masks])
        )
        assert rewards.shape == (2,)
    envs.close()


def test_sorting_cell_masks_raise_and_render(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "egl")
    env = gym.make("sortsim/SortingCell-v0", render_mode="rgb_array", **SMALL_CELL).unwrapped
    try:
        obs, info = env.reset(seed=2)
        mask = env.action_masks()
        assert np.array_equal(mask, info["action_mask"]) and mask[-1]
        empty = int(np.flatnonzero(~mask)[0])
        t0 = info["time_s"]
        for action in (empty, env.k_slots + 1, -1):
            with pytest.raises(InvalidAction, match="action"):
                env.step(action)
        assert env.episode.data.time == t0  # nothing stepped
        frame = env.render()
        video = env.config.video
        assert frame.shape == (video.height, video.width, 3) and frame.dtype == np.uint8
        assert env.metadata["render_fps"] == video.fps
        assert frame.std() > 10  # a picture, not a blank
        env.step(_first_slot(mask))
        later = env.render()
        assert np.abs(later.astype(int) - frame).max(axis=2).mean() > 0.5  # it moved on
        for _ in range(500):  # until an item lands in a bin
            *_, terminated, _, _ = env.step(_first_slot(env.action_masks()))
            if env.episode.parts.bins.landed or terminated:
                break
        overlay = overlay_of(env.episode.parts, env.episode.data.time, planner="agent")
        assert "agent" in overlay.counters[0] and overlay.counters[2].startswith("wrong bin 0")
        bins = {b.cls: b for b in overlay.bins}
        assert set(bins) == {2, 3, 4} and bins[2].y < 0 < bins[3].y  # paper's on its own side
        assert sum(b.count for b in bins.values()) == len(env.episode.parts.bins.landed) > 0
    finally:
        env.close()


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
