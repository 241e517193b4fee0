"""Episodes in time for the rollout planner (`planner.decision.managers.rollout`): the score of
each first move from the robot's state now.

Ours, after the thesis's 3.4.2, which keeps its picking "in real time", so that "the robot will
eventually lose items due to the movement of the conveyor belt". Each candidate first pick
starts one greedy episode. After it the robot is at that item's bin
when the release ends (the cycle-time model's clock); from there the item of highest reward
w = v / d among those it can still meet before they leave the window is taken, and so on, until
no item can be met or `steps` moves are made. q of the first pick is eq. 3.5 backwards along its
episode, q = w + gamma * q(next), so a first pick that makes the robot lose the valuable items
behind it scores lower than one that leaves time for them.

The thesis's stopping rule (stop when the remaining rewards sum to less than the most precious
one) is not applied here: in time, the belt ends an episode by carrying items away, and the rule
would cut the episode after a precious first pick and not after a cheap one (with a paper and an
aluminium item, value only, it made the robot take the paper first and lose nothing but the
aluminium's extra value). It still ends the reward path of
`planner.decision.managers.rollout.reward_path`.

Items are handled as plain tuples (id, x at t0, y, expected value, bin class) in this inner
loop; the meeting and place times are the same calls `planner.decision.candidates` makes.
"""

from __future__ import annotations

import math

from planner.decision.batch_grid import MIN_DISTANCE
from planner.decision.candidates import Candidate, intercept
from planner.decision.interface import DecisionContext


def weight(value: float, start_xy, meet_xy, bin_xy, objective: str, energy=None) -> float:
    """Eq. 3.3 (and the 4.1.3 variants): value over the distance start -> item -> bin [m];
    the value net of the pick's energy cost when `energy` (an `EnergyPrice`) prices it."""
    d = math.dist(start_xy, meet_xy) + math.dist(meet_xy, bin_xy)
    if energy is not None and energy.price_eur_per_kwh > 0.0:
        value = value - float(energy.cost_eur(d))
    d = max(d, MIN_DISTANCE)
    if objective == "d=1":
        return value
    if objective == "v=1":
        return 1.0 / d
    return value / d


def episode_q(
    first: Candidate,
    first_weight: float,
    others: list[tuple[int, float, float, float, int]],
    t0: float,
    context: DecisionContext,
    gamma: float,
    objective: str,
    steps: int,
) -> tuple[float, int]:
    """q of `first` [reward units] and the number of moves of its episode.

    Args:
        first: The first pick (timed from the decision at t0).
        first_weight: Its reward from the robot's position.
        others: The other items of the batch: (id, x at t0 [m], y [m], expected value [EUR],
            bin class).
        t0: Decision time [s].
        context: Belt speed, window, cycle-time model and bins.
        gamma: Discount of eq. 3.5.
        objective: 'v/d', 'd=1' or 'v=1'.
        steps: Most moves after the first.
    """
    v = context.belt_speed
    z = context.window.pick_z
    model = context.cycle_model
    t = first.end_time
    pos = context.bin_of(first.bin_class)
    left = list(others)
    collected = [first_weight]
    for _ in range(steps):
        best, best_w, alive = None, -math.inf, []
        for item in left:
            item_id, x0, y, value, bin_class = item
            met = intercept(context, pos, t, x0 + v * (t - t0), y)
            if met is None:
                continue  # lost: it leaves the window before the cup can get there
            alive.append(item)
            meet_time, meet_x, _ = met
            bin_xyz = context.bin_of(bin_class)
            w = weight(value, pos[:2], (meet_x, y), bin_xyz[:2], objective, context.energy)
            if w > best_w:
                best_w = w
                best = (item, meet_time + model.time_to_place((meet_x, y, z), bin_xyz), bin_xyz)
        if best is None:  # nothing left that the cup can meet
            break
        item, t, pos = best
        collected.append(best_w)
        left = [it for it in alive if it is not item]
    q = 0.0
    for w in reversed(collected):
        q = w + gamma * q
    return q, len(collected)
