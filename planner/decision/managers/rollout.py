"""Our time-aware rollout over the thesis's reward (ours, not the thesis's algorithm).

The thesis's Q-learning as written (random actions, 50 episodes, eq. 3.5 on the 20 x 27 grid)
is `planner.decision.managers.qlearning`. This planner keeps the thesis's grid, batches and reward
(eq. 3.3) but chooses by rollouts: nothing is drawn at random and nothing is learned.

- Grid and batches (`planner.decision.batch_grid`): rows one observation period apart, fixed to
  the belt, row 0 the first item seen; batches of 20 rows; the current batch is the most
  downstream one that still has a feasible pick, and each batch starts where the last one
  ended (the robot at the last bin, its real position). Items keep continuous coordinates.
- Weight (eq. 3.3): w = v / d, v the item's (expected) value and d the distance robot ->
  item -> bin in the belt plane, the item taken at the point the cup would meet it. Variants of
  4.1.3: 'd=1' (w = v) and 'v=1' (w = 1 / d).
- Reward matrix: one row of weights per robot position: its current position, then each bin
  (after a pick the robot is at that item's bin). A taken item's reward is zeroed.
- Only items the cup can meet now, inside the reachable window, by the cycle-time model, are
  candidates; an item still upstream of the window waits for a later decision.
- Rollouts in time (default, `episode_starts` > 0;
  `planner.decision.managers.rollout_episodes`): one greedy episode per candidate first pick
  (the `episode_starts` of highest reward), the robot released over that item's bin on the
  cycle-time model's clock, then taking the item of highest reward it can still meet, for up to
  `episode_steps` moves; the score of the first pick is the discounted sum w + gamma w' + ...
  along its episode. Items the belt carries away during an episode are lost to it, so a first
  pick is worth what it leaves the robot time for.
- Reward path (`episode_starts = 0`): the path taking the item of highest reward until the
  thesis's stopping rule (the rewards left sum to less than the most precious reward at the
  start), with q = w + gamma max q of the items left repeated along it until it stops changing
  or `iterations` passes are done.
- The score is one value per item, not the thesis's 20 x 27 q matrix. Objective O_total
  (eq. 3.4) plays no part in the choice.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.decision.batch_grid import (
    MIN_DISTANCE,
    LearningParameters,
    batch_index,
    belt_coordinate,
    grid_column,
)
from planner.decision.candidates import Candidate, candidates, choice_of
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem
from planner.decision.managers.rollout_episodes import episode_q
from planner.errors import PlannerInputError


@dataclass(frozen=True)
class RolloutConfig(LearningParameters):
    """Parameters of the rollout planner: the thesis's learning parameters
    (`LearningParameters`: gamma, iterations, batches, 3.4.1, 4.2) and

    Attributes:
        episode_starts: First picks (those of highest reward) whose episodes in time are run
            (`planner.decision.managers.rollout_episodes`); 0 chooses by the q of the reward
            path alone.
        episode_steps: Most moves of each such episode after its first pick.
    """

    episode_starts: int = 8
    episode_steps: int = 16

    def __post_init__(self):
        super().__post_init__()
        for name in ("episode_starts", "episode_steps"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise PlannerInputError(name, "an integer >= 0", value)


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


def weights(
    cands: list[Candidate], robot: RobotState, context: DecisionContext, objective: str
) -> tuple[np.ndarray, np.ndarray]:
    """(1 + m, n) weights from the robot and from each of the m bins, and each item's next
    row (its bin)."""
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
    next_state = np.array([c.bin_class - 1 for c in cands])
    return w, next_state


class RolloutPlanner:
    """Timed rollouts over the thesis's reward, on the current batch of feasible items."""

    name = "rollout"

    def __init__(self, config: RolloutConfig | None = None):
        self.config = config or RolloutConfig()
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
        batches = [
            batch_index(c.item, robot.time, v, cfg.row_period_s, cfg.batch_rows, self._origin)
            for c in cands
        ]
        current = min(batches)
        cands = [c for c, b in zip(cands, batches, strict=True) if b == current]
        w, next_state = weights(cands, robot, context, cfg.objective)
        if cfg.episode_starts:
            batch = [
                it
                for it in items
                if context.expected_value(it) > 0.0
                and batch_index(it, robot.time, v, cfg.row_period_s, cfg.batch_rows, self._origin)
                == current
            ]
            q, moves = self._episodes_in_time(cands, w[0], batch, robot, context)
            k = int(np.argmax(q))
            detail = f"episode of {moves[k]} moves"
        else:
            q, episodes = q_values(w, next_state, cfg.gamma, cfg.iterations, cfg.tolerance)
            k = int(np.argmax(q))
            detail = f"{episodes} episodes"
        col = grid_column(cands[k].item.y, context.belt_half_width)
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
