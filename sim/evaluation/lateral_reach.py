"""How much of a belt the robot reaches, and what it misses across it, by belt width.

    python -m sim.evaluation.lateral_reach [--widths 0.8,1.2] [--seeds 0-3] [--items 100]
        [--duration 90] [--perception truth] [--planner qlearning]

For each width (`[belt] width_m`) it prints the robot's reachable window at the pick height
(`sim.cell.robots.RobotView.window`): the lateral span it reaches, as a share of the belt's
width, and the window's length along the belt at the centre line and near the edges, and the
bins' release points (`sim.model.belt_width`). Then it
runs the episodes of the given seeds (one robot, the default headline episode otherwise) and
prints, per band of lateral position |y| of the items' centres, the items that entered and the
share of them not picked into a bin (missed, or dropped), with the episodes' totals of missed
and dropped items.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

BANDS_M = (0.0, 0.2, 0.4, 0.5, 0.55, 0.6)
"""Edges of the bands of |y| [m] the misses are counted in."""


def window_summary(width_m: float) -> dict[str, Any]:
    """The robot's window at the pick height on a belt `width_m` [m] wide: the |y| it reaches
    up to [m], that span's share of the width, the window's length along the belt [m] at
    y = 0 and at |y| = 0.55 m (0 where it does not reach), and the bins' release points
    (x, y, z) [m] by material."""
    from sim.cell.cell import Cell
    from sim.config.plant import CellSettings

    cell = Cell(settings=CellSettings(belt_width_m=width_m))
    robot = cell.robots[0]
    window = robot.window
    half = 0.5 * width_m
    ys = np.linspace(-half, half, 481)
    reached = [abs(y) for y in ys if window.bounds(float(y)) is not None]
    reach = max(reached) if reached else 0.0

    def length(y: float) -> float:
        b = window.bounds(y)
        return 0.0 if b is None else b[1] - b[0]

    return {
        "reach_m": reach,
        "share": min(2 * reach, width_m) / width_m,
        "length_centre_m": length(0.0),
        "length_055_m": length(0.55),
        "release": {
            cell.materials.name_of(c): tuple(float(v) for v in p) for c, p in robot.drop_xyz.items()
        },
    }


def band_outcomes(
    width_m: float, seeds, items: int, duration_s: float, perception: str, planner: str
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """(entered per band, not picked per band, missed, dropped) over the seeds' episodes."""
    from sim import config as episode_config
    from sim.episode.runner import run_episode
    from sim.flow.generator import generate_flow

    entered = np.zeros(len(BANDS_M) - 1, int)
    lost = np.zeros(len(BANDS_M) - 1, int)
    missed = dropped = 0
    for seed in seeds:
        config = episode_config.load(
            None,
            seed=seed,
            items=items,
            duration_s=duration_s,
            perception=perception,
            planner=planner,
        ).replace(belt=episode_config.Belt(width_m=width_m))
        flow = generate_flow(config.flow_config(), config.item_catalogue)
        result = run_episode(config)
        picked = {int(p["item_id"]) for p in result.pick_rows if p["success"]}
        band = np.digitize(np.abs(flow.y), BANDS_M[1:-1])
        not_picked = np.array([i not in picked for i in range(len(flow))])
        entered += np.bincount(band, minlength=len(entered))
        lost += np.bincount(band[not_picked], minlength=len(lost))
        missed += int(result.episode_row["missed"])
        dropped += int(result.episode_row["dropped"])
    return entered, lost, missed, dropped


def main(argv=None) -> int:
    """Command line: print the window and the per-band misses of each width."""
    from sim.flow.labelled_grids import parse_seeds

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--widths", default="0.8,1.2", help="belt widths [m], comma-separated")
    parser.add_argument("--seeds", default="0-3", help="seeds like 0-3 or 1,4,7")
    parser.add_argument("--items", type=int, default=100)
    parser.add_argument("--duration", type=float, default=90.0, help="feed duration [s]")
    parser.add_argument("--perception", default="truth", choices=("truth", "camera"))
    parser.add_argument("--planner", default="qlearning")
    args = parser.parse_args(argv)
    seeds = parse_seeds(args.seeds, "--seeds")
    for width in (float(w) for w in args.widths.split(",")):
        w = window_summary(width)
        print(
            f"belt {width:.2f} m: the cup reaches |y| <= {w['reach_m']:.3f} m "
            f"({100 * w['share']:.1f} % of the width) at the pick height; window "
            f"{w['length_centre_m']:.2f} m long on the centre line, {w['length_055_m']:.2f} m at "
            f"|y| = 0.55 m"
        )
        points = ", ".join(
            f"{n} ({x:.3f}, {y:.3f}, {z:.2f})" for n, (x, y, z) in w["release"].items()
        )
        print(f"  release points [m]: {points}")
        entered, lost, missed, dropped = band_outcomes(
            width, seeds, args.items, args.duration, args.perception, args.planner
        )
        for k, (n, m) in enumerate(zip(entered, lost, strict=True)):
            if n:
                lo, hi = BANDS_M[k], BANDS_M[k + 1]
                print(f"  |y| {lo:.2f}-{hi:.2f} m: {n:4d} items, {100 * m / n:5.1f} % not picked")
        total = int(entered.sum())
        print(
            f"  all: {total} items, {100 * lost.sum() / total:.1f} % not picked "
            f"(missed {missed}, dropped {dropped}; {args.perception}, seeds {args.seeds})"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
