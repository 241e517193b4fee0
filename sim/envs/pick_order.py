"""`sortsim/PickOrder-v0`: choosing the pick order on a kinematic belt (no physics).

Items ride a belt at one of the thesis's speeds; the robot's timing is the cycle-time model
fitted to the ruckig trajectories of the cell (`sim.episode.decision_view.cell_context`), with
the reach window and bins of the compiled scene: the rules of `planner.decision.kinematic_belt`,
which scores every decision manager. One step is one decision: pick the candidate in a slot
(the robot meets it, carries it to its bin, and the reward is its value if the bin is right),
or wait `idle_step_s`. The episode ends when every item has been picked or has left the window.

`action_masks()` (and `info["action_mask"]`) marks the slots holding a candidate, and wait; an
action the mask rules out raises `sim.envs.actions.InvalidAction` unless the environment was
made with `invalid_action="wait"` (then it waits). `render_mode="rgb_array"`: `render()` draws
the belt from above (`sim.envs.belt_picture`). docs/envs.md has the observation, the action,
the reward and examples.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from planner.decision.candidates import exit_time
from planner.decision.interface import RobotState, TrackedItem
from planner.decision.kinematic_belt import HOME_TCP, random_belt
from planner.decision.slot_features import bounds, choice_for, observe, slot_candidates
from planner.motion.belt_speeds import SPEED_FACTORS, SPEED_X1_MPS
from sim.envs import belt_picture
from sim.envs.actions import check_invalid_action, slot_of
from sim.episode.decision_view import cell_context
from sim.errors import InvalidInput


def _moved(item: TrackedItem, x: float) -> TrackedItem:
    """`item` carried by the belt to `x` [m]: a copy of the validated item (its probabilities
    and bin were checked once), so that a decision costs no re-validation."""
    moved = object.__new__(TrackedItem)
    moved.__dict__.update(item.__dict__)
    moved.__dict__["x"] = float(x)
    return moved


class PickOrderEnv(gym.Env):
    """Planner-level pick-order environment.

    Args:
        k_slots: Candidates shown per decision (the action space is k_slots + 1, the last wait).
        items: (min, max) items per belt, drawn per episode.
        rate: (min, max) arrival rate [items/s], drawn per episode (busy belts: the robot picks
            about 1.4 items/s).
        speed_factors: Belt speed factors drawn from per episode (x1 = 0.185 m/s).
        idle_step_s: Time a wait lets pass [s].
        view_start_x: Items upstream of this x [m] are not yet in view.
        render_mode: None, or "rgb_array": `render()` returns the belt from above (an RGB
            array, `sim.envs.belt_picture`).
        invalid_action: "raise" (default): an action the mask rules out, or outside the action
            space, raises `InvalidAction`; "wait": it is taken as waiting.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        k_slots: int = 8,
        items: tuple[int, int] = (20, 40),
        rate: tuple[float, float] = (1.5, 4.0),
        speed_factors: tuple[float, ...] = SPEED_FACTORS,
        idle_step_s: float = 0.05,
        view_start_x: float = -1.5,
        render_mode: str | None = None,
        invalid_action: str = "raise",
    ):
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise InvalidInput("render_mode", "None | rgb_array", render_mode)
        if not (isinstance(k_slots, int) and 1 <= k_slots <= 64):
            raise InvalidInput("k_slots", "an integer 1..64", k_slots)
        if not (1 <= items[0] <= items[1] <= 500):
            raise InvalidInput("items", "(min, max) with 1 <= min <= max <= 500", items)
        if not (0.0 < rate[0] <= rate[1]):
            raise InvalidInput("rate", "(min, max) items/s with 0 < min <= max", rate)
        if not (idle_step_s > 0.0):
            raise InvalidInput("idle_step_s", "> 0 s", idle_step_s)
        self.k_slots, self.items, self.rate = k_slots, items, rate
        self.speed_factors = tuple(float(f) for f in speed_factors)
        self.idle_step_s, self.view_start_x = float(idle_step_s), float(view_start_x)
        self.render_mode = render_mode
        self.invalid_action = check_invalid_action(invalid_action)
        low, high = bounds(k_slots)
        self.observation_space = gym.spaces.Box(low, high, dtype=np.float32)
        self.action_space = gym.spaces.Discrete(k_slots + 1)
        self._contexts: dict[float, object] = {}

    def _context(self, speed: float):
        if speed not in self._contexts:
            self._contexts[speed] = cell_context(speed)
        return self._contexts[speed]

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        rng = self.np_random
        speed = SPEED_X1_MPS * float(rng.choice(self.speed_factors))
        n = int(rng.integers(self.items[0], self.items[1] + 1))
        length = n * speed / float(rng.uniform(*self.rate))
        self.belt = random_belt(rng, n, length, speed, start_x=0.4)
        self.context = self._context(speed)
        self.t, self.tcp = 0.0, HOME_TCP
        self.left = {it.item_id: it for it in self.belt.items}
        # Validated once; each decision shifts copies along the belt (see `_moved`).
        self._tracked = {
            it.item_id: TrackedItem(it.item_id, it.x0, it.y, it.class_probs)
            for it in self.belt.items
        }
        self.profit, self.picked = 0.0, 0
        self._binned: dict[int, int] = {}
        self._advance_to_decision()
        return self._obs, self._info()

    def _advance_to_decision(self) -> None:
        """Drop lost items; wait while nothing is feasible; observe the candidates."""
        v, ctx = self.belt.speed, self.context
        while True:
            t = self.t
            lost = [k for k, it in self.left.items() if exit_time(ctx, t, it.x0 + v * t, it.y) <= t]
            for k in lost:
                del self.left[k]
            if not self.left:
                self._cands, self._done = [], True
                self._obs, self._mask = observe([], t, self.k_slots)
                return
            seen = [
                _moved(self._tracked[k], it.x0 + v * t)
                for k, it in self.left.items()
                if it.x0 + v * t >= self.view_start_x
            ]
            self._cands = slot_candidates(seen, RobotState(self.tcp, t), ctx, self.k_slots)
            if self._cands:
                self._done = False
                self._obs, self._mask = observe(self._cands, t, self.k_slots)
                return
            self.t += self.idle_step_s

    def _info(self) -> dict:
        return {
            "action_mask": self._mask.copy(),
            "time_s": self.t,
            "profit_eur": self.profit,
            "picked": self.picked,
            "items": len(self.belt.items),
        }

    def action_masks(self) -> np.ndarray:
        """The action mask now: (k_slots + 1,) bool, True for a slot holding a candidate and
        for wait (the last); what MaskablePPO asks for."""
        return self._mask.copy()

    def step(self, action):
        slot = slot_of(action, self._mask, self.invalid_action)
        choice = choice_for(slot, self._cands, self.k_slots)
        reward = 0.0
        if choice is None:
            self.t += self.idle_step_s
        else:
            cand = next(c for c in self._cands if c.item.item_id == choice.item_id)
            item = self.left.pop(choice.item_id)
            if choice.bin_class == item.true_class:
                reward = self.context.value_of(item.true_class)
            self.profit += reward
            self.picked += 1
            self._binned[choice.bin_class] = self._binned.get(choice.bin_class, 0) + 1
            self.t, self.tcp = cand.end_time, self.context.bin_of(choice.bin_class)
        self._advance_to_decision()
        return self._obs, float(reward), self._done, False, self._info()

    def render(self):
        """The belt from above (`sim.envs.belt_picture`) with `render_mode="rgb_array"`: an RGB
        array (520, 800, 3) uint8; None without a render mode."""
        if self.render_mode != "rgb_array":
            return None
        v, t = self.belt.speed, self.t
        window = self.context.window
        scene = belt_picture.BeltScene(
            items=[(it.x0 + v * t, it.y, it.true_class) for it in self.left.values()],
            candidates=[(c.item.x, c.item.y) for c in self._cands],
            tcp=(float(self.tcp[0]), float(self.tcp[1])),
            window=(np.asarray(window.y), np.asarray(window.x_entry), np.asarray(window.x_exit)),
            bins={k + 2: (b[0], b[1]) for k, b in enumerate(self.context.bins)},
            binned=dict(self._binned),
            view_start_x=self.view_start_x,
            counters=f"t {t:5.1f} s   belt {v:.3f} m/s   picked {self.picked} of "
            f"{len(self.belt.items)}   profit {self.profit:.2f} EUR",
            belt_half_width=self.context.belt_half_width,
        )
        return belt_picture.draw(scene)
