"""`sortsim/SortingCell-v0`: choosing the pick order in the physics of the cell.

A step is one decision of a steppable `sim.episode.loop.Episode`: the agent picks the candidate
in a slot or waits, then the physics runs (the pick, the belt, perception, bins) until the robot
is free and a choice is due again. The reward is the profit earned since the last decision
[EUR] (an item counts when it lands in its bin). Truth or camera perception, as configured.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from planner.decision.slot_features import bounds, choice_for, observe, slot_candidates
from sim.episode import config as episode_config
from sim.episode.loop import Episode
from sim.episode.runner import config_cell


class SortingCellEnv(gym.Env):
    """Physics pick-order environment.

    Args:
        k_slots: Candidates shown per decision (the action space is k_slots + 1, the last wait).
        **config: Episode settings as for `sortsim run` (`items`, `duration_s`, `speed_factor`,
            `perception`, ...), validated like a config file; the seed comes from `reset`.
    """

    metadata = {"render_modes": []}

    def __init__(self, k_slots: int = 8, **config):
        self.config = episode_config.load(None, **{"perception": "truth", **config})
        self.k_slots = int(k_slots)
        low, high = bounds(self.k_slots)
        self.observation_space = gym.spaces.Box(low, high, dtype=np.float32)
        self.action_space = gym.spaces.Discrete(self.k_slots + 1)
        self.episode: Episode | None = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if self.episode is not None:
            self.episode.close()
        episode_seed = int(self.np_random.integers(0, 2**31 - 1))
        cell = config_cell(self.config)
        self.episode = Episode(self.config, cell)
        self.episode.reset(seed=episode_seed)
        self._profit = 0.0
        self._advance()
        return self._obs, self._info()

    def _advance(self) -> None:
        episode = self.episode
        self._running = episode.step_until_decision()
        robot = episode.robot_state()
        items = episode.candidates() if self._running else []
        self._cands = slot_candidates(items, robot, episode.context, self.k_slots)
        self._obs, self._mask = observe(self._cands, robot.time, self.k_slots)

    def _info(self) -> dict:
        m = self.episode.metrics
        return {
            "action_mask": self._mask.copy(),
            "time_s": float(self.episode.data.time),
            "profit_eur": float(m.profit),
            "picked": int(m.n_picked),
            "entered": int(m.n_entered),
        }

    def step(self, action):
        if self._running:
            self.episode.apply(choice_for(int(action), self._cands, self.k_slots))
            self._advance()
        profit = float(self.episode.metrics.profit)
        reward, self._profit = profit - self._profit, profit
        return self._obs, reward, not self._running, False, self._info()

    def close(self) -> None:
        if self.episode is not None:
            self.episode.close()
            self.episode = None
