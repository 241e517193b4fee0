"""Fit the decision managers' cycle-time model to the pick controller's plans in physics.

    python -m sim.evaluation.cell_cycle_fit [--workers 2]

Runs physics episodes, truth perception, on training seeds (100-105: every decision manager,
the thesis's three belt speeds, busy belts of 100 items over 90 s and saturated ones of 300-400),
records every pick as the controller planned it (`PickController.started`), fits the closed
form's two calibrations to them (`sim.episode.cycle_timing.fit_to_plans`) and prints the
coefficients for `CELL_PICK_COEF` and `CELL_PLACE_COEF` with the cycle-time errors, as the
decision managers predict (waits included), of the model in use, of the bare-pick calibration
and of the new fit, on the training episodes and on held-out ones (seeds 200-202).
"""

from __future__ import annotations

import argparse
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import numpy as np

TRAINING = (
    (100, "proximity", 1.0, 100, 90.0),
    (101, "lookahead", 1.5, 100, 90.0),
    (102, "rollout", 1.2, 300, 135.0),
    (103, "fifo", 1.0, 400, 191.0),
    (104, "qlearning", 1.2, 200, 90.0),
    (105, "learned", 1.0, 100, 90.0),
)
"""(seed, planner, speed factor, items, seconds over which they arrive) of the fit."""
HELD_OUT = (
    (200, "lookahead", 1.2, 300, 135.0),
    (201, "proximity", 1.0, 300, 151.0),
    (202, "rollout", 1.5, 100, 90.0),
)
"""Episodes the fit is checked on."""


def _started_picks(spec):
    """(belt speed [m/s], started picks) of one truth episode."""
    from sim.config import EpisodeConfig
    from sim.episode.loop import Episode
    from sim.episode.runner import shared_cell

    seed, planner, factor, items, duration = spec
    config = EpisodeConfig(
        seed=seed,
        items=items,
        speed_factor=factor,
        planner=planner,
        perception="truth",
        duration_s=duration,
    )
    with Episode(config, shared_cell()) as episode:
        episode.reset()
        episode.run()
        return config.belt_speed_mps, list(episode.robot.started)


def _errors_line(name: str, context, picks, speeds) -> str:
    from sim.episode.cycle_timing import cycle_errors

    e = cycle_errors(context, picks, speeds)
    return (
        f"  {name:<22} {len(e):4d} picks: bias {e.mean() * 1e3:+6.1f} ms, "
        f"rms {np.sqrt(np.mean(e**2)) * 1e3:5.1f} ms, 95 % of |error| below "
        f"{np.percentile(np.abs(e), 95) * 1e3:5.1f} ms"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2, choices=range(1, 9))
    args = parser.parse_args(argv)
    from planner.motion.cycle_model import PICK_COEF, PLACE_COEF, CycleTimeModel
    from sim.episode.cycle_timing import fit_to_plans
    from sim.episode.decision_view import cell_context

    with ProcessPoolExecutor(args.workers) as pool:
        runs = list(pool.map(_started_picks, TRAINING + HELD_OUT))

    def flat(part):
        speeds = [v for v, picks in part for _ in picks]
        return [p for _, picks in part for p in picks], speeds

    train, test = flat(runs[: len(TRAINING)]), flat(runs[len(TRAINING) :])
    context = cell_context(runs[0][0])
    in_use = context.cycle_model
    assert isinstance(in_use, CycleTimeModel)  # the cell's calibrated model
    bare = replace(in_use, pick_coef=PICK_COEF, place_coef=PLACE_COEF)
    fitted = fit_to_plans(context, *train)
    print(f"CELL_PICK_COEF = ({fitted.pick_coef[0]:.4f}, {fitted.pick_coef[1]:.4f})")
    print(f"CELL_PLACE_COEF = ({fitted.place_coef[0]:.4f}, {fitted.place_coef[1]:.4f})")
    for label, (picks, speeds) in (("training", train), ("held out", test)):
        print(f"{label} episodes, planned minus predicted cycle time:")
        for name, model in (("bare-pick calibration", bare), ("in use", in_use), ("fit", fitted)):
            print(_errors_line(name, replace(context, cycle_model=model), picks, speeds))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
