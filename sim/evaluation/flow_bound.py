"""The profit bound of an episode's whole flow, and the best order found on it replayed in physics.

`flow_facts` reads an episode config's flow as the episode makes it (`sim.episode.builder`):
each item's place at t = 0 (dropped at `X_INFEED` at its spawn time, riding at the belt's
speed), its class and value, and the first robot's decision context (its reach window, bins,
and cycle-time model with the regime's pauses). `bound_of` is the relaxation of
`planner.decision.flow_bound` on it: no pick order timed by the cycle-time model earns more. It
is not proven for the physics' robot (`time_scale` measures how much faster than the model's
least times a physics run's picks were; the tests check the physics' runs against it).

`best_order` searches with the whole flow known (`planner.decision.managers.best_order`, the
planner `best_order`: the look-ahead planner on the kinematic belt with every item in view from
t = 0). `replay` runs that order in physics; its profit is what the best known order earns
there, a lower bound on the best order's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.decision.flow_bound import FlowBound, interval_bound, pick_place_times, reach_windows
from planner.decision.interface import DecisionContext
from planner.decision.managers.best_order import search_order
from planner.decision.managers.follow_order import FollowOrderPlanner
from planner.decision.oracle import pick_lower_bound, place_lower_bound
from sim.config import EpisodeConfig
from sim.flow.config import X_INFEED


@dataclass(frozen=True)
class FlowFacts:
    """An episode's flow as a bound sees it (arrays by flow item id).

    Attributes:
        x0: x of each item at t = 0 [m] (upstream of the infeed before its spawn).
        y: Its y [m].
        classes: Its class id (2 paper, 3 plastic, 4 aluminium).
        values: What binning it earns [EUR].
        context: The first robot's decision context.
    """

    x0: np.ndarray
    y: np.ndarray
    classes: np.ndarray
    values: np.ndarray
    context: DecisionContext


def flow_facts(config: EpisodeConfig) -> FlowFacts:
    """The flow, values and context of `config`'s episode (no physics stepped)."""
    from sim.episode import builder
    from sim.episode.runner import config_cell

    cell = config_cell(config, sized=True)
    flow = builder.episode_flow(config, cell)
    controller = builder.pick_controllers(config, cell, flow)[0]
    context = builder.station_context(config, cell, cell.robots[0], controller)
    metrics = builder.episode_metrics(config, cell, flow)
    classes = np.asarray(flow.class_id, dtype=int)
    values = np.array(
        [metrics.item_values.get(j, metrics.values[int(c)]) for j, c in enumerate(classes)]
    )
    x0 = X_INFEED - config.belt_speed_mps * np.asarray(flow.t_spawn, dtype=float)
    return FlowFacts(x0, np.asarray(flow.y, dtype=float), classes, values, context)


def bound_of(facts: FlowFacts, scale: float = 1.0) -> FlowBound:
    """The most any pick order can earn on the flow [EUR] (`interval_bound`), the least pick
    and place times times `scale` (`time_scale`)."""
    release, deadline = reach_windows(facts.context, facts.x0, facts.y)
    pick, place = pick_place_times(facts.context, facts.y, facts.classes, scale)
    return interval_bound(release, deadline, facts.values, pick, place)


def time_scale(facts: FlowFacts, pick_rows: list[dict]) -> float:
    """The least ratio, over a physics run's picks (picks.csv rows of the flow), of the pick's
    cycle (its start at the last bin to its end) to the least pick and place times from that
    bin to that item (1 when none is faster): the bound's times are scaled by it, so no pick
    measured in physics is faster than the relaxation allows. The first pick (from the robot's
    rest) and picks that did not end in a bin are left out."""
    ids = {row["true_class"]: int(facts.classes[int(row["item_id"])]) for row in pick_rows}
    ratio = 1.0
    where = None
    for row in pick_rows:
        j, bin_class = int(row["item_id"]), ids.get(row["bin"])
        if where is not None and bin_class is not None:
            lower = pick_lower_bound(facts.context, where, float(facts.y[j])) + place_lower_bound(
                facts.context, float(facts.y[j]), bin_class
            )
            if lower > 0.0:
                ratio = min(ratio, float(row["cycle_s"]) / lower)
        where = None if bin_class is None else facts.context.bin_of(bin_class)
    return ratio


def best_order(facts: FlowFacts) -> tuple[tuple[int, ...], float]:
    """(order of flow ids, its profit on the kinematic belt [EUR]) of `SEARCH` with the whole
    flow in view from the start (`search_order`)."""
    return search_order(facts.x0, facts.y, facts.classes, facts.context)


def replay(config: EpisodeConfig, facts: FlowFacts, order: tuple[int, ...]) -> dict:
    """The episode of `config` with `order` followed in physics: its episodes.csv row, with
    `followed` (picks that followed the order)."""
    from sim.episode.runner import run_episode

    planner = FollowOrderPlanner(order, facts.x0, facts.y)
    row = dict(run_episode(config, planner=planner).episode_row)
    row["followed"] = planner.followed
    return row


def main(argv=None) -> int:
    """One flow: the bound, the best known order (kinematic, and replayed in physics) and
    proximity in physics, printed."""
    import argparse

    from sim.config import from_dict
    from sim.episode.runner import run_episode

    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("--items", type=int, default=80)
    parser.add_argument("--duration", type=float, default=62.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--speed-factor", type=float, default=1.0)
    parser.add_argument("--pause", type=float, default=0.0, help="pick and place pause [s]")
    args = parser.parse_args(argv)
    config = from_dict(
        {
            "perception": "truth",
            "planner": "proximity",
            "items": args.items,
            "duration_s": args.duration,
            "seed": args.seed,
            "speed_factor": args.speed_factor,
            "robot": {"pick_pause_s": args.pause, "place_pause_s": args.pause},
        }
    )
    facts = flow_facts(config)
    bound = bound_of(facts)
    order, kinematic = best_order(facts)
    replayed = replay(config, facts, order)
    proximity = run_episode(config)
    print(
        f"bound {bound.bound:.2f} EUR (reachable {bound.reachable_value:.2f}, least gap "
        f"{bound.gap_s:.3f} s, {bound.constraints} cuts); best known order: kinematic "
        f"{kinematic:.2f}, physics {replayed['profit_eur']:.2f} ({replayed['followed']} of its "
        f"{len(order)} items chosen); proximity {proximity.episode_row['profit_eur']:.2f}; "
        f"least measured / bound time over proximity's picks "
        f"{time_scale(facts, proximity.pick_rows):.3f}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
