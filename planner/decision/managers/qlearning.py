"""The thesis's decision manager as written: Q-learning over a 20 x 27 batch of the belt grid.

What the thesis specifies, and how it is read here (the section each choice interprets):

- State and action space (3.4, 3.4.1, annex part three). The belt is a grid
  (`planner.decision.batch_grid`): rows one observation period of belt travel apart (row pitch
  = belt speed x `row_period_s`), fixed to the belt, row 0 the first item seen; 27 columns, 25
  across the belt and the bin columns 1 and 27. It is handed to the learner in batches of
  `batch_rows` (20) rows. An item is the grid cell of its centroid (the thesis's k-means
  centroids; here the tracker's position); an action is the cell of an item still on the
  belt. Two items in one cell: the later one (less urgent) takes the nearest free cell, as a
  cell holds one centroid. The robot is at its start position or at one of the three bins.
- Reward (eq. 3.3, 4.1.3, annex part two): w = v / d, v the item's expected value (p(class) x
  value of table 3.3) and d the distance robot -> item -> bin, d = 1 for the 'd=1' variant and
  v = 1 for 'v=1'. The annex's code measures robot -> item only; eq. 3.3 says "the total
  distance required for the robot to pick item x and place it in the respective bin", which we
  follow. Distances are in metres between the cell centre (at the learning time) and the
  robot's real position and bin release points (the annex measures in cells; at x1 our cells
  are 0.0925 x 0.032 m, so cell units would stretch the belt's width threefold). The reward is
  recomputed from wherever the robot is (the start, then the bin of its last pick).
- q (3.4.1, figure 3.4, eq. 3.5): a matrix of the batch's shape (20 x 27), one value per cell
  whatever the robot's position, as the thesis's; initialised at random ("randomly
  initialized"): uniform in [0, `q_init` x the largest reward), so that a learned value
  outweighs an initial one. The update is q(a) <- w(s, a) + gamma max q(a') over
  the items still on the belt after a (0 when none is left: the terminal state). The annex's
  code takes that maximum before zeroing the taken item's reward, and over every row of one
  item crossed with every column of another; we follow the text (the next state's actions,
  figure 3.4's max_a Q(S', a)) and take it over the remaining items' cells.
- Episodes (annex part three, "choose an action at random"): from the robot's position each
  step takes an item drawn uniformly at random among those left (`numpy.random.Generator`
  seeded by `seed`; the episode runner passes its own seed), updates its q, zeroes its reward
  and moves the robot to that item's bin.
- Stopping rule (3.4.1): an episode ends when the rewards of the items left, from where the
  robot now is, sum to less than the reward of the most precious item, read as the largest
  reward at the episode's start (against the largest one left the rule could never fire), or
  when no item is left.
- Iterations (3.4.1, 4.2): episodes repeat until an episode changes no q by more than
  `tolerance` ("until it acquires the best q matrix possible") or 50 have run.
- Final path (3.4.2): the item of maximum q in the batch's matrix is picked; the next decision
  takes the maximum of those left, and so on ("deleted from the list of the potential picks").
  Time (3.4.2: "make the picking selection based on how much time the robot would have in the
  real world"): only items the cup can meet now, inside the reachable window, on the cycle-time
  model's clock, can be chosen (an item still upstream of the window waits for a later
  decision); an item the belt carries away is lost. Ties go to the item that leaves first.
- Batches (3.4.2): the current batch is the most downstream one that still has an item the cup
  can meet; "the starting point of the robot ... is the last position of the robot from the
  exact previous sequence": learning starts from the robot's real position. q is learned when
  a batch becomes current and again when items of it are seen for the first time (the thesis
  had whole batches from its prediction matrix; ours arrive row by row past the camera); items
  picked or lost since do not trigger a new learning.

Objective O_total (eq. 3.4) scores a finished path; it plays no part in the choice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.decision.batch_grid import (
    BELT_COLUMNS,
    GRID_COLUMNS,
    MIN_DISTANCE,
    LearningParameters,
    batch_index,
    belt_coordinate,
    column_centre,
    grid_column,
    grid_row,
)
from planner.decision.candidates import candidates, choice_of, exit_time
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem
from planner.errors import PlannerInputError


@dataclass(frozen=True)
class QLearningConfig(LearningParameters):
    """Parameters of the thesis's learner (defaults: sections 3.4, 3.4.1 and 4.2): the
    learning parameters (`LearningParameters`) and

    Attributes:
        seed: Seed of the random initial q and of the random actions (>= 0).
        q_init: Initial q drawn uniformly in [0, q_init x the largest reward) (>= 0).
    """

    seed: int = 0
    q_init: float = 0.01

    def __post_init__(self):
        super().__post_init__()
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise PlannerInputError("seed", "an integer >= 0", self.seed)
        q = self.q_init
        finite = isinstance(q, int | float) and not isinstance(q, bool) and math.isfinite(q)
        if not (finite and q >= 0.0):
            raise PlannerInputError("q_init", "a number >= 0", q)


@dataclass(frozen=True)
class Learned:
    """The outcome of learning on one batch.

    Attributes:
        q: (batch_rows, 27) q matrix; only the items' cells were updated.
        cells: Grid cell (row in the batch, column 0..26) of each item, in the order given.
        episodes: Episodes run (the last one changed no q by more than the tolerance, or it
            was the 50th).
        steps: Items taken over all episodes.
    """

    q: np.ndarray
    cells: tuple[tuple[int, int], ...]
    episodes: int
    steps: int

    def q_of(self, k: int) -> float:
        """q of item k."""
        r, c = self.cells[k]
        return float(self.q[r, c])


def learn(
    rewards: np.ndarray,
    next_state: np.ndarray,
    cells: list[tuple[int, int]],
    shape: tuple[int, int],
    gamma: float,
    iterations: int,
    rng: np.random.Generator,
    tolerance: float = 1e-12,
    q_init: float = 0.01,
) -> Learned:
    """The thesis's Q-learning on one batch (3.4.1 and the annex, part three).

    Args:
        rewards: (S, n) reward of each item from each robot position; row 0 is the start.
        next_state: (n,) row of `rewards` the robot is at after taking each item (its bin).
        cells: Distinct grid cell (row, column) of each item.
        shape: Shape of the q matrix (batch rows, 27).
        gamma: Discount of eq. 3.5.
        iterations: Most episodes.
        rng: Draws the initial q (`rng.random(shape)`), then per episode one uniform u per item
            (`rng.random(n)`); step i takes the item at index floor(u_i x number left) of the
            items left, kept in the order given.
        tolerance: An episode that changes no q by more than this ends the learning.
        q_init: Scale of the random initial q, relative to the largest reward.

    Returns:
        The learned matrix and what it took.
    """
    n = rewards.shape[1]
    if len(cells) != n or len(next_state) != n or len(set(cells)) != n:
        raise PlannerInputError("cells", "one distinct cell per item", len(cells))
    top = float(rewards.max()) if rewards.size else 0.0
    q = rng.random(shape) * q_init * top
    table = rewards.tolist()
    nxt = [int(s) for s in next_state]
    qi = [float(q[r, c]) for r, c in cells]  # q of the items' cells, kept in step with q
    actions = [k for k in range(n) if table[0][k] > 0.0]  # "find(reward > 0)"
    precious = max((table[0][k] for k in actions), default=0.0)
    episodes = steps = 0
    for _ in range(iterations):
        episodes += 1
        before = list(qi)
        state, left = 0, list(actions)
        # What each step needs, kept up to date as items are taken: the rewards left from
        # each robot position, and the items left by q (the q of an item still on the belt
        # does not change during the episode: only the taken item's does).
        sums = [sum(row[b] for b in left) for row in table]
        by_q = sorted(left, key=lambda b: -qi[b])
        gone: set[int] = set()
        top_k = 0
        draws = rng.random(len(left)).tolist()
        while left:
            a = left.pop(int(draws[len(gone)] * len(left)))  # "choose an action at random"
            gone.add(a)
            for s, row in enumerate(table):
                sums[s] -= row[a]
            while top_k < len(by_q) and by_q[top_k] in gone:
                top_k += 1
            max_q = qi[by_q[top_k]] if top_k < len(by_q) else 0.0
            qi[a] = table[state][a] + gamma * max(max_q, 0.0)  # eq. 3.5
            steps += 1
            state = nxt[a]  # the robot places the item in its bin
            if left and sums[state] < precious:
                break  # the stopping rule of 3.4.1
        if max((abs(x - y) for x, y in zip(qi, before, strict=True)), default=0.0) <= tolerance:
            break
    for (r, c), value in zip(cells, qi, strict=True):
        q[r, c] = value
    return Learned(q, tuple(cells), episodes, steps)


def rewards_from(
    points: np.ndarray,
    values: np.ndarray,
    bins_xy: np.ndarray,
    starts_xy: np.ndarray,
    objective: str,
    energy=None,
) -> np.ndarray:
    """(S, n) rewards of eq. 3.3 from each robot position.

    Args:
        points: (n, 2) item positions (cell centres) [m].
        values: (n,) expected values [EUR].
        bins_xy: (n, 2) release point of each item's bin [m].
        starts_xy: (S, 2) robot positions [m].
        objective: 'v/d', 'd=1' or 'v=1'.
        energy: An `EnergyPrice`: when it prices energy, each value is net of the pick's
            energy cost over its distance (ours; the thesis's reward has no such term).
    """
    d = np.linalg.norm(points[None, :, :] - starts_xy[:, None, :], axis=2)
    d = np.maximum(d + np.linalg.norm(bins_xy - points, axis=1)[None, :], MIN_DISTANCE)
    if energy is not None and energy.price_eur_per_kwh > 0.0:
        values = np.asarray(values, dtype=float)[None, :] - energy.cost_eur(d)
    if objective == "d=1":
        return np.broadcast_to(values, d.shape).astype(float)
    if objective == "v=1":
        return np.where(np.broadcast_to(values, d.shape) > 0.0, 1.0 / d, 0.0)
    return np.broadcast_to(values, d.shape) / d


def assign_cells(wanted: list[tuple[int, int]], rows: int) -> list[tuple[int, int]]:
    """Distinct cells: an item whose cell is taken by an earlier one gets the nearest free belt
    cell (fewest rows plus columns away, then fewest rows, then lower row and column)."""
    taken: set[tuple[int, int]] = set()
    out = []
    for r, c in wanted:
        if (r, c) in taken:
            free = [
                (rr, cc)
                for rr in range(rows)
                for cc in range(1, 1 + BELT_COLUMNS)
                if (rr, cc) not in taken
            ]
            if not free:
                raise PlannerInputError("items", f"at most {rows * BELT_COLUMNS} in a batch")
            r, c = min(free, key=lambda rc: (abs(rc[0] - r) + abs(rc[1] - c), abs(rc[0] - r), rc))
        taken.add((r, c))
        out.append((r, c))
    return out


class QLearningPlanner:
    """The thesis's Q-learning (3.4.1, annex) on the current batch; picks by maximum q (3.4.2)."""

    name = "qlearning"

    def __init__(self, config: QLearningConfig | None = None):
        self.config = config or QLearningConfig()
        self.reset()

    def reset(self) -> None:
        """Start of an episode: the grid's first row, the learned batch and the random stream
        start again from the seed."""
        self._origin: float | None = None
        self._rng = np.random.default_rng(self.config.seed)
        self._batch: int | None = None
        self._known: frozenset[int] = frozenset()
        self._q: dict[int, float] = {}
        self._learned: Learned | None = None

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """The item of maximum q among those of the current batch the cup can meet now."""
        cfg = self.config
        cands = candidates(items, robot, context, immediate_only=True, with_place=False)
        if not cands:
            return None
        v, t = context.belt_speed, robot.time
        if self._origin is None:  # the stream's first row is where the first item seen is
            self._origin = max(belt_coordinate(it, t, v) for it in items)

        def batch_of(item):
            return batch_index(item, t, v, cfg.row_period_s, cfg.batch_rows, self._origin)

        current = min(batch_of(c.item) for c in cands)
        cands = [c for c in cands if batch_of(c.item) == current]
        batch = [
            it
            for it in items
            if batch_of(it) == current
            and context.expected_value(it) > 0.0
            and exit_time(context, t, it.x, it.y) > t
        ]
        ids = frozenset(it.item_id for it in batch)
        if current != self._batch or not ids <= self._known:
            self._learn(batch, current, robot, context)
        q = [self._q.get(c.item.item_id, -math.inf) for c in cands]
        k = max(range(len(cands)), key=lambda i: (q[i], -i))  # ties: the earlier exit
        column = grid_column(cands[k].item.y, context.belt_half_width)
        assert self._learned is not None  # learned over the current batch above
        return choice_of(
            cands[k],
            f"max q {q[k]:.4f} of batch {current} ({len(self._q)} items, "
            f"{self._learned.episodes} episodes), column {column}",
        )

    def _learn(self, batch, current, robot, context) -> None:
        """Learn q over the batch's items from the robot's position now."""
        cfg = self.config
        v, t = context.belt_speed, robot.time
        assert self._origin is not None  # set by choose before it learns
        batch = sorted(batch, key=lambda it: (exit_time(context, t, it.x, it.y), it.item_id))
        first_row = current * cfg.batch_rows
        rows = [grid_row(it, t, v, cfg.row_period_s, self._origin) - first_row for it in batch]
        wanted = [
            (min(max(r, 0), cfg.batch_rows - 1), grid_column(it.y, context.belt_half_width) - 1)
            for r, it in zip(rows, batch, strict=True)
        ]
        cells = assign_cells(wanted, cfg.batch_rows)
        pitch = v * cfg.row_period_s
        # Cell centres now: row r of the batch is (first_row + r + 0.5) pitches upstream of the
        # belt coordinate of row 0, which has moved v t downstream since t = 0.
        points = np.array(
            [
                (
                    self._origin + v * t - (first_row + r + 0.5) * pitch if v > 0.0 else it.x,
                    column_centre(c + 1, context.belt_half_width),
                )
                for (r, c), it in zip(cells, batch, strict=True)
            ]
        ).reshape(-1, 2)
        values = np.array([context.expected_value(it) for it in batch])
        bins_xy = np.array([context.bin_of(it.bin_class)[:2] for it in batch]).reshape(-1, 2)
        starts = np.array([robot.tcp[:2], *(b[:2] for b in context.bins)])
        rewards = rewards_from(points, values, bins_xy, starts, cfg.objective, context.energy)
        next_state = np.array([it.bin_class - 1 for it in batch], dtype=int)
        learned = learn(
            rewards,
            next_state,
            cells,
            (cfg.batch_rows, GRID_COLUMNS),
            cfg.gamma,
            cfg.iterations,
            self._rng,
            cfg.tolerance,
            cfg.q_init,
        )
        self._batch, self._known, self._learned = (
            current,
            frozenset(it.item_id for it in batch),
            learned,
        )
        self._q = {it.item_id: learned.q_of(k) for k, it in enumerate(batch)}
