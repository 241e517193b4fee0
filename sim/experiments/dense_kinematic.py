"""The tables' dense datasets on the kinematic belt: every decision manager in seconds.

    python -m sim.experiments.dense_kinematic [--seeds 0-4] [--planners lookahead,rollout,...]

The flows of tables 4.5 and 4.6's dense rows (300 and 400 items; x1 over 151 and 191 s, x1.2
over 135 and 174 s), the same items at the same times as the physics episodes of those seeds
(`sim.flow.generator.generate_flow`), replayed on the kinematic belt
(`planner.decision.kinematic_belt.simulate`: no physics, the robot's times from the cell's
cycle-time model, which is calibrated on the physics' picks: `sim.episode.cycle_timing`), truth
perception. Prints the mean profit [EUR] and picks per dataset and planner. The planners'
parameters for these belts were chosen on seeds 1000-1002; evaluate on others.
"""

from __future__ import annotations

import argparse

import numpy as np

DATASETS = ((300, 151.0, 1.0), (400, 191.0, 1.0), (300, 135.0, 1.2), (400, 174.0, 1.2))
"""(items, seconds over which they arrive, belt speed factor) of the dense rows."""
PLANNERS = ("lookahead", "rollout", "proximity", "qlearning", "learned", "fifo")


def flow_belt(seed: int, items: int, duration_s: float, speed_factor: float):
    """The kinematic belt carrying the flow of an episode with these settings."""
    from planner.decision.kinematic_belt import Belt, BeltItem, one_hot
    from planner.motion.belt_speeds import SPEED_X1_MPS
    from sim.flow.catalogue import load_catalogue
    from sim.flow.config import X_INFEED, FlowConfig
    from sim.flow.generator import generate_flow

    config = FlowConfig(n_items=items, duration_s=duration_s, speed_factor=speed_factor, seed=seed)
    flow = generate_flow(config, load_catalogue())
    speed = SPEED_X1_MPS * speed_factor
    belt_items = []
    for i in range(len(flow)):
        cls = int(flow.class_id[i])
        x0 = X_INFEED - speed * float(flow.t_spawn[i])
        belt_items.append(BeltItem(i, x0, float(flow.y[i]), cls, one_hot(cls)))
    return Belt(tuple(belt_items), speed)


def _seeds(text: str) -> list[int]:
    try:
        if "-" in text:
            lo, hi = (int(p) for p in text.split("-"))
            seeds = list(range(lo, hi + 1))
        else:
            seeds = [int(p) for p in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError("seeds: 'A-B' or 'A,B,...' of integers >= 0") from None
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError("seeds: 'A-B' or 'A,B,...' of integers >= 0")
    return seeds


def _planners(text: str) -> list[str]:
    names = text.split(",")
    if not names or any(n not in PLANNERS for n in names):
        raise argparse.ArgumentTypeError(f"planners: comma-separated of {', '.join(PLANNERS)}")
    return names


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=_seeds, default=_seeds("0-4"), help="e.g. 0-4")
    parser.add_argument("--planners", type=_planners, default=list(PLANNERS))
    args = parser.parse_args(argv)
    from planner.decision.kinematic_belt import simulate
    from planner.decision.registry import make_planner
    from sim.episode.decision_view import cell_context

    seeds = args.seeds
    print(f"mean profit [EUR] (picks), seeds {seeds[0]}..{seeds[-1]} ({len(seeds)}), truth")
    for items, duration, factor in DATASETS:
        cells = []
        for name in args.planners:
            profit, picks = [], []
            for seed in seeds:
                belt = flow_belt(seed, items, duration, factor)
                ctx = cell_context(belt.speed)
                result = simulate(make_planner(name), belt, ctx, start_tcp=ctx.bins[0])
                profit.append(result.profit)
                picks.append(len(result.picks))
            cells.append(f"{name} {np.mean(profit):.2f} ({np.mean(picks):.1f})")
        print(f"{items} items x{factor}: " + ", ".join(cells), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
