"""A sorting line as a multi-agent environment, in PettingZoo's parallel API.

Agents are the line's robots, `robot_0` upstream to `robot_{N-1}`, each its own policy over the
pick order; the physics is a steppable `sim.episode.loop.Episode` of the line (its tracking
shared, no item taken twice, the coordination's `independent` rule: every robot is offered every
item no other robot holds, so what the robots learn is the coordination).

The robots' decisions are events of the physics: a robot is free when its pick ends, and two
robots are almost never free at the same millisecond. So each `step` is one decision of one
robot, the one named in every agent's info as `deciding`: its observation shows its own `k_slots`
most urgent candidates (as `sortsim/SortingCell-v0`'s, x measured from its base), its action
picks one or waits; the other agents see zeros, their action masks allow only waiting, and their
actions are ignored. The reward is the line's profit earned since the last step [EUR], the same
for every agent (a cooperative game); every agent terminates when the episode ends.

Each agent's mask is in its info (`infos[agent]["action_mask"]`) and also asked for directly:
`action_mask(agent)`, or `action_masks()` for every agent. The deciding robot's action that its
mask rules out is taken as waiting by default (`invalid_action="wait"`: PettingZoo's
`parallel_api_test` samples actions without masks); `invalid_action="raise"` refuses it
(`sim.envs.actions.InvalidAction`). The other agents' actions are ignored either way.

The API is PettingZoo's `ParallelEnv` (`reset`, `step` on dicts keyed by agent,
`observation_space(agent)`, `action_space(agent)`, `agents`, `possible_agents`), written out here
so that the default install needs no PettingZoo; `tests/test_line_env.py` runs PettingZoo's own
`parallel_api_test` on it.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from planner.decision.slot_features import N_FEATURES, bounds, choice_for, observe, slot_candidates
from sim import config as episode_config
from sim.envs.actions import check_invalid_action, slot_of
from sim.episode.loop import Episode
from sim.episode.runner import config_cell
from sim.errors import InvalidInput


class SortingLineParallelEnv:
    """Physics pick-order environment of a line of robots (see the module docstring).

    Args:
        robots: Robots of the line, 2..4.
        k_slots: Candidates shown per decision (each action space is k_slots + 1, the last wait).
        invalid_action: "wait" (default): the deciding robot's action that its mask rules out
            waits; "raise": it raises `InvalidAction`.
        **config: Episode settings as for `sortsim run` (`items`, `duration_s`, `speed_factor`,
            `perception`, ...), validated like a config file; the seed comes from `reset`.
    """

    metadata = {"render_modes": [], "name": "sortsim_line_v0", "is_parallelizable": True}

    def __init__(self, robots: int = 2, k_slots: int = 8, invalid_action: str = "wait", **config):
        if not (isinstance(robots, int) and 2 <= robots <= episode_config.MAX_ROBOTS):
            raise InvalidInput("robots", f"2..{episode_config.MAX_ROBOTS}", robots)
        settings = {"perception": "truth", **config, "robots": robots}
        self.config = episode_config.load(None, **{**settings, "coordination": "independent"})
        self.k_slots = int(k_slots)
        self.invalid_action = check_invalid_action(invalid_action)
        self.possible_agents = [f"robot_{k}" for k in range(robots)]
        self._low, self._high = bounds(self.k_slots)
        self._observation_spaces = {
            a: gym.spaces.Box(self._low, self._high, dtype=np.float32) for a in self.possible_agents
        }
        self._action_spaces = {
            a: gym.spaces.Discrete(self.k_slots + 1) for a in self.possible_agents
        }
        self.agents: list[str] = []
        self._deciding: str | None = None
        self._mask = np.zeros(self.k_slots + 1, dtype=bool)
        self.render_mode = None
        self.episode: Episode | None = None
        self._rng = np.random.default_rng()

    def observation_space(self, agent: str) -> gym.spaces.Box:
        """The agent's observation space (the same object at every call)."""
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> gym.spaces.Discrete:
        """The agent's action space: a slot, or `k_slots` to wait."""
        return self._action_spaces[agent]

    def reset(self, seed: int | None = None, options: dict | None = None):
        """Start an episode of a flow drawn from `seed`; returns (observations, infos)."""
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        if self.episode is not None:
            self.episode.close()
        self.episode = Episode(self.config, config_cell(self.config))
        self.episode.reset(seed=int(self._rng.integers(0, 2**31 - 1)))
        self.agents = list(self.possible_agents)
        self._profit = 0.0
        self._advance()
        return self._observations(), self._infos()

    def step(self, actions: dict):
        """Apply the deciding robot's action (the others' are ignored) and run the physics to
        the next decision; returns (observations, rewards, terminations, truncations, infos)."""
        assert self.episode is not None  # made by reset
        if self._running and self._deciding is not None:
            action = actions.get(self._deciding, self.k_slots)
            slot = slot_of(action, self._mask, self.invalid_action)
            self.episode.apply(choice_for(slot, self._cands, self.k_slots))
            self._advance()
        profit = float(self.episode.metrics.profit)
        reward, self._profit = profit - self._profit, profit
        observations, infos = self._observations(), self._infos()
        agents = self.agents
        rewards = dict.fromkeys(agents, reward)
        terminations = dict.fromkeys(agents, not self._running)
        truncations = dict.fromkeys(agents, False)
        if not self._running:
            self.agents = []
        return observations, rewards, terminations, truncations, infos

    def _advance(self) -> None:
        """Run the physics until a robot decides (or the episode ends)."""
        episode = self.episode
        assert episode is not None  # made by reset
        self._running = episode.step_until_decision()
        self._deciding = None
        self._cands = []
        self._obs = np.zeros(self.k_slots * N_FEATURES, dtype=np.float32)
        self._mask = np.zeros(self.k_slots + 1, dtype=bool)
        if not self._running:
            return
        index = episode.deciding_robot
        robot = episode.robot_state()
        self._deciding = self.possible_agents[index]
        self._cands = slot_candidates(episode.candidates(), robot, episode.context, self.k_slots)
        obs, self._mask = observe(self._cands, robot.time, self.k_slots)
        base_x = episode.cell.robots[index].base_x
        slots = obs.reshape(self.k_slots, N_FEATURES)
        slots[: len(self._cands), 1] -= base_x  # x from the deciding robot's base [m]
        self._obs = np.clip(obs, self._low, self._high)

    def _observations(self) -> dict[str, np.ndarray]:
        idle = np.zeros(self.k_slots * N_FEATURES, dtype=np.float32)
        return {a: self._obs.copy() if a == self._deciding else idle.copy() for a in self.agents}

    def action_mask(self, agent: str) -> np.ndarray:
        """The agent's action mask now, (k_slots + 1,) bool: the deciding robot's candidates
        and wait; wait only for the others (and for every agent once the episode ended)."""
        if agent == self._deciding:
            return self._mask.copy()
        wait_only = np.zeros(self.k_slots + 1, dtype=bool)
        wait_only[self.k_slots] = True
        return wait_only

    def action_masks(self) -> dict[str, np.ndarray]:
        """Every live agent's action mask (`action_mask`)."""
        return {a: self.action_mask(a) for a in self.agents}

    def _infos(self) -> dict[str, dict]:
        assert self.episode is not None  # made by reset
        m = self.episode.metrics
        shared = {
            "deciding": self._deciding,
            "time_s": float(self.episode.data.time),
            "profit_eur": float(m.profit),
            "picked": int(m.n_picked),
            "entered": int(m.n_entered),
        }
        return {a: {**shared, "action_mask": self.action_mask(a)} for a in self.agents}

    @property
    def num_agents(self) -> int:
        return len(self.agents)

    @property
    def max_num_agents(self) -> int:
        return len(self.possible_agents)

    @property
    def unwrapped(self) -> SortingLineParallelEnv:
        return self

    def render(self) -> None:
        """No rendering (`sortsim view` and `--video` show a line)."""

    def state(self) -> np.ndarray:
        """The deciding robot's observation (the line's global state is the physics)."""
        return self._obs.copy()

    def close(self) -> None:
        if self.episode is not None:
            self.episode.close()
            self.episode = None
