"""The thesis's decision manager (sections 3.4, 4.1.3): Q-learning over the items of a batch.

Reading of the thesis, where it leaves room (each choice marked so it can be revisited):

- Grid and batches (3.4): the belt is a grid of 27 columns (two bin columns and 25 across the
  belt) whose rows are one observation period apart (0.5 s of belt travel); rows are fixed to
  the belt, so an item keeps its row as it moves, and row 0 holds the first item the planner
  sees (the start of the thesis's sequence). The items are handed to the learner in batches
  of 20 rows; the current batch is the most downstream one that still has a feasible pick, and
  each batch starts where the last one ended (the robot at the last bin, its real position).
  Items are centroids with continuous coordinates, as the thesis's k-means centroids are.
- Weight (eq. 3.3): w = v / d, v the item's (expected) value and d the distance robot ->
  item -> bin in the belt plane, the item taken at the point the cup would meet it. Variants of
  4.1.3: 'd=1' (w = v) and 'v=1' (w = 1 / d).
- Reward matrix: one row of weights per robot position: its current position, then each bin
  (after a pick the robot is at that item's bin, 3.4.1). A taken item's reward is zeroed.
- Episode: from the robot's position, "movements are selected based on their reward" (3.4.1):
  the available item of highest reward is taken, q(item) = w + gamma * max q over the items
  still available (eq. 3.5), its reward zeroed and the robot moved to its bin. The episode
  ends by the stopping rule of 3.4.1: when the sum of the rewards of the remaining items (from
  where the robot now is) is smaller than the reward of the most precious item (the highest
  reward at the episode's start).
- Iterations: episodes repeat until q stops changing or `iterations` (50) are done. q starts at
  zero (the thesis initialises it randomly; zero keeps runs reproducible and is the value of
  the terminal state). Because the behaviour policy selects by reward, every episode follows
  the same path; it is computed once and the updates are repeated along it, which gives the
  same q as replaying the episodes.
- Choice (3.4.2): the item of maximum q in the batch; ties go to the item leaving first.
- Time (3.4.2, "how much time the robot would have in the real world ... the robot will
  eventually lose items due to the movement of the conveyor belt"): only items the cup can
  meet now, inside the reachable window, by the cycle-time model, are candidates; an item still
  upstream of the window waits for a later decision (the reward has no notion of waiting). By
  default (`episode_starts` > 0) the episodes run in time as well
  (`planner.decision.rollout_episodes`):
  one episode per candidate first pick (the `episode_starts` of highest reward), the robot
  released over that item's bin on the cycle-time model's clock, then taking the item of
  highest reward it can still meet, for up to `episode_steps` moves; q of the first pick is
  eq. 3.5 along its episode. Items the belt carries away during an episode are lost to it, so a
  first pick is worth what it leaves the robot time for. On seeded dense belts (the cycle-time
  model's simulator, `tests/test_decision_qlearning.py`) this earns more than the proximity
  picker and than the reward path's q alone (`episode_starts = 0`, the first reading).
- q is one value per item (the thesis's q matrix has the reward matrix's 20 x 27 shape), not per
  (robot position, item): the continuation term of an item is the best q among the items left,
  whatever bin the robot would then be at. Objective O_total (eq. 3.4) is the thesis's score
  of a finished path and plays no part in the choice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.decision.candidates import Candidate, candidates, choice_of
from planner.decision.interface import MATERIALS, Choice, DecisionContext, RobotState, TrackedItem
from planner.decision.rollout_episodes import MIN_DISTANCE, episode_q
from planner.errors import PlannerInputError

OBJECTIVES = ("v/d", "d=1", "v=1")
BELT_COLUMNS = 25
GRID_COLUMNS = BELT_COLUMNS + 2


@dataclass(frozen=True)
class QLearningConfig:
    """Parameters of the thesis's learner (defaults: section 3.4.1 and 4.2).

    Attributes:
        gamma: Discount factor of eq. 3.5, in [0, 1).
        iterations: Maximum number of episodes (>= 1).
        batch_rows: Grid rows per batch (>= 1).
        row_period_s: Belt travel time of one grid row [s] (the observation period).
        objective: 'v/d' (eq. 3.3), 'd=1' (value only) or 'v=1' (distance only), section 4.1.3.
        tolerance: Largest q change that counts as converged.
        episode_starts: First picks (those of highest reward) whose episodes in time are run
            (`planner.decision.rollout_episodes`); 0 chooses by the q of the reward path alone.
        episode_steps: Most moves of each such episode after its first pick.
    """

    gamma: float = 0.9
    iterations: int = 50
    batch_rows: int = 20
    row_period_s: float = 0.5
    objective: str = "v/d"
    tolerance: float = 1e-12
    episode_starts: int = 8
    episode_steps: int = 16

    def __post_init__(self):
        if not (isinstance(self.gamma, int | float) and 0.0 <= self.gamma < 1.0):
            raise PlannerInputError("gamma", "a number in [0, 1)", self.gamma)
        for name in ("episode_starts", "episode_steps"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise PlannerInputError(name, "an integer >= 0", value)
        for name in ("iterations", "batch_rows"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise PlannerInputError(name, "an integer >= 1", value)
        if not (math.isfinite(self.row_period_s) and self.row_period_s > 0.0):
            raise PlannerInputError("row_period_s", "a period > 0 [s]", self.row_period_s)
        if self.objective not in OBJECTIVES:
            raise PlannerInputError("objective", " | ".join(OBJECTIVES), self.objective)
        if not (math.isfinite(self.tolerance) and self.tolerance >= 0.0):
            raise PlannerInputError("tolerance", "a number >= 0", self.tolerance)


def reward_path(rewards: np.ndarray, next_state: np.ndarray) -> tuple[list[int], list[float]]:
    """The episode's path: items taken by highest reward until the stopping rule.

    Args:
        rewards: (S, n) weight of each item from each robot position; row 0 is the start.
        next_state: (n,) row of `rewards` the robot is at after taking each item (its bin).

    Returns:
        The items taken, in order, and the reward collected at each step.
    """
    table = rewards.tolist()
    nxt = [int(s) for s in next_state]
    avail = list(range(rewards.shape[1]))
    precious = max(table[0])
    state, path, collected = 0, [], []
    while avail:
        row = table[state]
        a = max(avail, key=lambda i: (row[i], -i))  # ties: the earlier (more urgent) item
        path.append(a)
        collected.append(row[a])
        avail.remove(a)
        state = nxt[a]
        if avail and sum(table[state][i] for i in avail) < precious:
            break
    return path, collected


def q_values(
    rewards: np.ndarray, next_state: np.ndarray, gamma: float, iterations: int, tol: float = 0.0
) -> tuple[np.ndarray, int]:
    """q of every item after the episodes (eq. 3.5), and the number of episodes run."""
    path, collected = reward_path(rewards, next_state)
    qp = [0.0] * len(path)  # q of the path's items; the never-taken ones stay 0
    episodes = iterations
    for episode in range(1, iterations + 1):
        # Items still available after step k: the later path items (this episode updates them
        # after step k, so their q is the last episode's) and the never-taken ones (q = 0).
        later = [0.0] * (len(path) + 1)
        for k in range(len(path) - 1, -1, -1):
            later[k] = max(later[k + 1], qp[k])
        new = [collected[k] + gamma * later[k + 1] for k in range(len(path))]
        change = max((abs(a - b) for a, b in zip(new, qp, strict=True)), default=0.0)
        qp = new
        if change <= tol:
            episodes = episode
            break
    q = np.zeros(rewards.shape[1])
    q[path] = qp
    return q, episodes


def belt_coordinate(item: TrackedItem, t: float, belt_speed: float) -> float:
    """Where the item was at t = 0 [m]: a coordinate fixed to the belt."""
    return item.x - belt_speed * t


def batch_index(
    item: TrackedItem, t: float, belt_speed: float, cfg: QLearningConfig, origin: float = 0.0
) -> int:
    """Batch of an item: its grid row // batch_rows, rows counted upstream from the belt
    coordinate `origin` [m] (row 0 holds the first item seen); 0 on a stopped belt."""
    if belt_speed <= 0.0:
        return 0
    u = belt_coordinate(item, t, belt_speed)
    row = math.floor((origin - u) / (belt_speed * cfg.row_period_s))
    return row // cfg.batch_rows


def grid_column(y: float, half_width: float = 0.4) -> int:
    """Grid column 2..26 of a belt position y [m] (1 and 27 are the bin columns)."""
    k = int((y + half_width) / (2 * half_width) * BELT_COLUMNS)
    return 2 + min(max(k, 0), BELT_COLUMNS - 1)


def weights(
    cands: list[Candidate], robot: RobotState, context: DecisionContext, objective: str
) -> tuple[np.ndarray, np.ndarray]:
    """(4, n) weights from the robot and from each bin, and each item's next row (its bin)."""
    starts = np.array([robot.tcp[:2], *(b[:2] for b in context.bins)])
    meet = np.array([c.meet_xy for c in cands])
    dest = np.array([context.bin_of(c.bin_class)[:2] for c in cands])
    d = np.linalg.norm(meet[None, :, :] - starts[:, None, :], axis=2)
    d = np.maximum(d + np.linalg.norm(dest - meet, axis=1)[None, :], MIN_DISTANCE)
    v = np.array([c.expected_value for c in cands])
    if objective == "d=1":
        w = np.broadcast_to(v, d.shape).copy()
    elif objective == "v=1":
        w = 1.0 / d
    else:
        w = v[None, :] / d
    next_state = np.array([1 + MATERIALS.index(c.bin_class) for c in cands])
    return w, next_state


class QLearningPlanner:
    """The thesis's decision manager over the current batch of feasible items."""

    name = "qlearning"

    def __init__(self, config: QLearningConfig | None = None):
        self.config = config or QLearningConfig()
        self._origin: float | None = None

    def reset(self) -> None:
        """Forget the grid's first row (start of an episode)."""
        self._origin = None

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """The item of maximum q in the most downstream batch with a feasible pick."""
        cfg = self.config
        timed = cfg.episode_starts > 0  # the episodes go on from the release over the bin
        cands = candidates(items, robot, context, immediate_only=True, with_place=timed)
        if not cands:
            return None
        v = context.belt_speed
        if self._origin is None:  # the stream's first row is where the first item seen is
            self._origin = max(belt_coordinate(it, robot.time, v) for it in items)
        batches = [batch_index(c.item, robot.time, v, cfg, self._origin) for c in cands]
        current = min(batches)
        cands = [c for c, b in zip(cands, batches, strict=True) if b == current]
        w, next_state = weights(cands, robot, context, cfg.objective)
        if cfg.episode_starts:
            batch = [
                it
                for it in items
                if context.expected_value(it) > 0.0
                and batch_index(it, robot.time, v, cfg, self._origin) == current
            ]
            q, moves = self._episodes_in_time(cands, w[0], batch, robot, context)
            k = int(np.argmax(q))
            detail = f"episode of {moves[k]} moves"
        else:
            q, episodes = q_values(w, next_state, cfg.gamma, cfg.iterations, cfg.tolerance)
            k = int(np.argmax(q))
            detail = f"{episodes} episodes"
        col = grid_column(cands[k].item.y)
        return choice_of(
            cands[k],
            f"max q {q[k]:.4f} (w {w[0, k]:.4f}), batch {current}, column {col}, "
            f"{len(cands)} items, {detail}",
        )

    def _episodes_in_time(self, cands, w0, batch, robot, context):
        """q [reward units] and episode length of each candidate first pick; -inf for the
        candidates outside the `episode_starts` of highest reward."""
        cfg = self.config
        q = np.full(len(cands), -np.inf)
        moves = [0] * len(cands)
        for k in np.argsort(-w0, kind="stable")[: cfg.episode_starts]:
            first = cands[k]
            others = [
                (it.item_id, it.x, it.y, context.expected_value(it), it.bin_class)
                for it in batch
                if it.item_id != first.item.item_id
            ]
            q[k], moves[k] = episode_q(
                first,
                float(w0[k]),
                others,
                robot.time,
                context,
                cfg.gamma,
                cfg.objective,
                cfg.episode_steps,
            )
        return q, moves
