"""What a learning agent (or the `learned` decision manager) sees at a decision: the K most
urgent pick candidates as features.

Shared by both environments (planner level and physics). A slot holds one feasible candidate
(`planner.decision.candidates`), most urgent first (earliest exit from the reachable window);
slots past the last candidate are zeros with `present = 0`. Action k < K picks the candidate in
slot k; action K waits. The action mask marks the slots that hold a candidate, and wait.
"""

from __future__ import annotations

import numpy as np

from planner.decision.candidates import Candidate, choice_of, evaluate, exit_time
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem

FEATURES = (
    "present",
    "x_m",
    "y_m",
    "p_paper",
    "p_plastic",
    "p_aluminium",
    "expected_value_eur",
    "time_left_s",
    "time_to_reach_s",
)
"""Features per slot, in order: present (0/1), position at the decision [m], the class
probabilities of the three materials, expected value [EUR], time until the item leaves the
reachable window [s], time until the cup could meet it [s]."""
N_FEATURES = len(FEATURES)
MAX_TIME_S = 60.0
"""Times are clipped to this [s] so the observation stays in its box."""
LOW = np.array([0.0, -4.0, -0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], dtype=np.float32)
HIGH = np.array([1.0, 2.0, 0.5, 1.0, 1.0, 1.0, 10.0, MAX_TIME_S, MAX_TIME_S], dtype=np.float32)


def slot_candidates(
    items: list[TrackedItem], robot: RobotState, context: DecisionContext, k_slots: int
) -> list[Candidate]:
    """The `k_slots` most urgent feasible candidates (fewer when fewer are feasible): the first
    `k_slots` of `candidates(items, robot, context)`, found by timing the items in order of
    their exit from the window (which does not depend on the robot) until `k_slots` are
    feasible, instead of timing every item in view."""
    t = robot.time
    urgent = sorted(
        ((exit_time(context, t, it.x, it.y), it.item_id, it) for it in items),
        key=lambda entry: entry[:2],
    )
    out = []
    for _, _, item in urgent:
        if context.expected_value(item) <= 0.0:
            continue
        cand = evaluate(context, robot.tcp, t, item)
        if cand is not None and cand.expected_value > 0.0:
            out.append(cand)
            if len(out) == k_slots:
                break
    return out


def observe(cands: list[Candidate], now: float, k_slots: int) -> tuple[np.ndarray, np.ndarray]:
    """(observation (K * N_FEATURES,) float32, action mask (K + 1,) bool) of the candidates."""
    obs = np.zeros((k_slots, N_FEATURES), dtype=np.float32)
    for k, c in enumerate(cands[:k_slots]):
        probs = c.item.class_probs
        obs[k] = (
            1.0,
            c.item.x,
            c.item.y,
            probs[1],
            probs[2],
            probs[3],
            c.expected_value,
            c.exit_time - now,
            c.meet_time - now,
        )
    obs = np.clip(obs, LOW, HIGH)
    mask = np.zeros(k_slots + 1, dtype=bool)
    mask[: min(len(cands), k_slots)] = True
    mask[k_slots] = True  # waiting is always allowed
    return obs.reshape(-1), mask


def choice_for(action: int, cands: list[Candidate], k_slots: int) -> Choice | None:
    """The choice an action makes: the candidate in its slot, or None (wait, or an empty slot)."""
    if 0 <= action < min(len(cands), k_slots):
        return choice_of(cands[action], f"agent: slot {action}")
    return None


def bounds(k_slots: int) -> tuple[np.ndarray, np.ndarray]:
    """The observation box's (low, high) for `k_slots` slots."""
    return np.tile(LOW, k_slots), np.tile(HIGH, k_slots)
