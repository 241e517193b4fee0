"""`sortsim/SortingCell-v0`: choosing the pick order in the physics of the cell.

A step is one decision of a steppable `sim.episode.loop.Episode`: the agent picks the candidate
in a slot or waits, then the physics runs (the pick, the belt, perception, bins) until the robot
is free and a choice is due again. The reward is the profit earned since the last decision
[EUR] (an item counts when it lands in its bin). Truth or camera perception, as configured.

`action_masks()` (and `info["action_mask"]`) marks the slots holding a candidate, and wait; an
action the mask rules out raises `sim.envs.actions.InvalidAction` unless the environment was
made with `invalid_action="wait"` (then it waits). `render_mode="rgb_array"`: `render()` returns
the frame the episode's video would show now (`sim.render.painter.FramePainter`: the video's
view, labels and counters, at the config's `[video]` size); it needs an off-screen OpenGL
back-end (`MUJOCO_GL=egl`). docs/envs.md has the observation, the action, the reward and
examples.
"""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np

from planner.decision.slot_features import bounds, choice_for, observe, slot_candidates
from sim import config as episode_config
from sim.envs.actions import check_invalid_action, slot_of
from sim.episode.loop import Episode
from sim.episode.overlay import overlay_of
from sim.episode.runner import config_cell
from sim.errors import InvalidInput


class SortingCellEnv(gym.Env):
    """Physics pick-order environment.

    Args:
        k_slots: Candidates shown per decision (the action space is k_slots + 1, the last wait).
        render_mode: None, or "rgb_array": `render()` returns the video's frame of the cell now
            (an RGB array of the config's `[video]` size; needs `MUJOCO_GL=egl` or `osmesa`).
        invalid_action: "raise" (default): an action the mask rules out, or outside the action
            space, raises `InvalidAction`; "wait": it is taken as waiting.
        **config: Episode settings as for `sortsim run` (`items`, `duration_s`, `speed_factor`,
            `perception`, ...), validated like a config file; the seed comes from `reset`.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10.0}

    def __init__(
        self,
        k_slots: int = 8,
        render_mode: str | None = None,
        invalid_action: str = "raise",
        **config,
    ):
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise InvalidInput("render_mode", "None | rgb_array", render_mode)
        self.render_mode = render_mode
        self.invalid_action = check_invalid_action(invalid_action)
        self.config = episode_config.load(None, **{"perception": "truth", **config})
        self.metadata = {**self.metadata, "render_fps": float(self.config.video.fps)}
        self._painter = None
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
        assert episode is not None  # made by reset
        self._running = episode.step_until_decision()
        robot = episode.robot_state()
        items = episode.candidates() if self._running else []
        self._cands = slot_candidates(items, robot, episode.context, self.k_slots)
        self._obs, self._mask = observe(self._cands, robot.time, self.k_slots)

    def _info(self) -> dict:
        assert self.episode is not None  # made by reset
        m = self.episode.metrics
        return {
            "action_mask": self._mask.copy(),
            "time_s": float(self.episode.data.time),
            "profit_eur": float(m.profit),
            "picked": int(m.n_picked),
            "entered": int(m.n_entered),
        }

    def action_masks(self) -> np.ndarray:
        """The action mask now: (k_slots + 1,) bool, True for a slot holding a candidate and
        for wait (the last); what MaskablePPO asks for."""
        return self._mask.copy()

    def step(self, action):
        slot = slot_of(action, self._mask, self.invalid_action)
        if self._running:
            self.episode.apply(choice_for(slot, self._cands, self.k_slots))
            self._advance()
        profit = float(self.episode.metrics.profit)
        reward, self._profit = profit - self._profit, profit
        return self._obs, reward, not self._running, False, self._info()

    def render(self):
        """The video's frame of the cell now with `render_mode="rgb_array"` (its labels and
        counters drawn over it): an RGB array (height, width, 3) uint8 of the config's
        `[video]` size; None without a render mode."""
        if self.render_mode != "rgb_array" or self.episode is None:
            return None
        from sim.render.painter import FramePainter, ModelWatch, frame_state

        model = self.episode.model
        if self._painter is None or self._painter[0] is not model:
            self._close_painter()
            start = copy.deepcopy(model)
            watch = ModelWatch(start)
            video = self.config.video
            self._painter = (model, watch, FramePainter(start, video.width, video.height))
        _, watch, painter = self._painter
        data = self.episode.cell.items.current()
        painter.apply(frame_state(model, data, watch))
        return painter.paint(overlay_of(self.episode.parts, float(data.time), planner="agent"))

    def _close_painter(self) -> None:
        if self._painter is not None:
            self._painter[2].close()
            self._painter = None

    def close(self) -> None:
        self._close_painter()
        if self.episode is not None:
            self.episode.close()
            self.episode = None
