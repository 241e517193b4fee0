"""The line as a multi-agent environment (PettingZoo's parallel API) in physics."""

from __future__ import annotations

import numpy as np
import pytest

from sim.envs.sorting_line import SortingLineParallelEnv
from sim.errors import InvalidInput

SMALL = {"items": 24, "duration_s": 8.0}


def _play(env: SortingLineParallelEnv, seed: int, policy_seed: int = 0):
    """One episode with a random policy over each deciding robot's allowed actions; returns
    (per step: the deciding agent, the reward) and the last infos."""
    rng = np.random.default_rng(policy_seed)
    observations, infos = env.reset(seed=seed)
    trace = []
    while env.agents:
        actions = {}
        for agent in env.agents:
            mask = infos[agent]["action_mask"]
            actions[agent] = int(rng.choice(np.flatnonzero(mask)))
        deciding = infos[env.agents[0]]["deciding"]
        observations, rewards, terminations, truncations, infos_next = env.step(actions)
        assert set(rewards) == set(terminations) == set(truncations) == set(actions)
        assert len(set(rewards.values())) == 1  # one shared reward
        trace.append((deciding, next(iter(rewards.values()))))
        if env.agents:
            infos = infos_next
    return trace, infos


def test_the_line_env_passes_pettingzoos_parallel_api_test():
    test = pytest.importorskip("pettingzoo.test")
    env = SortingLineParallelEnv(robots=2, **SMALL)
    test.parallel_api_test(env, num_cycles=200)
    env.close()


def test_one_robot_decides_per_step_and_the_rewards_add_up_to_the_profit():
    env = SortingLineParallelEnv(robots=2, **SMALL)
    observations, infos = env.reset(seed=3)
    assert env.agents == ["robot_0", "robot_1"]
    for agent in env.agents:
        assert env.observation_space(agent).contains(observations[agent])
        deciding = infos[agent]["deciding"]
        mask = infos[agent]["action_mask"]
        if agent == deciding:
            assert mask.sum() >= 2  # a candidate and waiting
        else:
            assert mask.sum() == 1 and mask[-1]  # waiting only
            assert not observations[agent].any()
    trace, last = _play(env, seed=3)
    assert env.agents == []
    profit = env.episode.metrics.profit
    assert sum(r for _, r in trace) == pytest.approx(profit, abs=1e-9)
    assert profit > 0.0
    # both robots decided, and both picked (their picks add up to the line's)
    assert {d for d, _ in trace} == {"robot_0", "robot_1"}
    robots = [p.robot for p in env.episode.metrics.picks if p.success]
    assert set(robots) == {0, 1}
    env.close()


def test_the_line_env_is_deterministic_by_seed():
    env = SortingLineParallelEnv(robots=2, **SMALL)
    first, _ = _play(env, seed=5, policy_seed=1)
    second, _ = _play(env, seed=5, policy_seed=1)
    assert first == second
    env.close()


@pytest.mark.parametrize("robots", [1, 5, "2"])
def test_a_line_env_of_a_bad_robot_count_is_refused(robots):
    with pytest.raises(InvalidInput, match="robots"):
        SortingLineParallelEnv(robots=robots)


def test_each_agents_mask_is_asked_for_and_raise_refuses_a_masked_out_action():
    from sim.envs.actions import InvalidAction

    env = SortingLineParallelEnv(robots=2, invalid_action="raise", **SMALL)
    observations, infos = env.reset(seed=3)
    masks = env.action_masks()
    assert set(masks) == set(env.agents)
    for agent in env.agents:
        assert np.array_equal(env.action_mask(agent), infos[agent]["action_mask"])
    deciding = infos[env.agents[0]]["deciding"]
    mask = masks[deciding]
    t0 = env.episode.data.time
    if not mask.all():
        with pytest.raises(InvalidAction, match="action"):
            env.step({deciding: int(np.flatnonzero(~mask)[0])})
    with pytest.raises(InvalidAction, match="0..8"):
        env.step({deciding: 9})
    assert env.episode.data.time == t0
    _, rewards, *_ = env.step({deciding: int(np.flatnonzero(mask)[0])})  # allowed: it steps
    assert set(rewards) == {"robot_0", "robot_1"}
    env.close()
