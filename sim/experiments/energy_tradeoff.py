"""The motors' energy against profit: the pick-energy model the planners price, and the
trade-off at a tariff and at stress prices (issue: decision managers; docs/results.md).

    python -m sim.experiments.energy_tradeoff fit        # seeds 100-104: the model's constants
    python -m sim.experiments.energy_tradeoff tradeoff   # seeds 0-4 at each price

`fit` runs the headline truth episode (100 items, x1, `lookahead`) on the tuning seeds and fits
E = fixed + per_metre x d to the regenerative-free electrical energy of every pick against its
distance d (the thesis's: rest -> item -> bin), least squares with both terms >= 0; the result
goes into `planner.decision.energy_cost`. `tradeoff` runs the same episode on the evaluation
seeds at each price and prints picks, profit, energy, its cost and the net profit per price.
"""

from __future__ import annotations

import argparse
import multiprocessing
import statistics
import sys

import numpy as np
from scipy.optimize import nnls

FIT_SEEDS = tuple(range(100, 105))
EVAL_SEEDS = tuple(range(5))
PRICES_EUR_PER_KWH = (0.0, 0.30, 1000.0, 2500.0)
"""No price, an industrial tariff, and two stress prices at which a pick costs about a third
and about four fifths of what the cheapest item earns."""


def _episode(args: tuple[int, str, float]) -> tuple[dict, list[dict]]:
    from sim import config
    from sim.episode.runner import run_episode

    seed, planner, price = args
    cfg = config.load(
        None, seed=seed, planner=planner, perception="truth", energy_price_eur_per_kwh=price
    )
    result = run_episode(cfg)
    return result.episode_row, result.pick_rows


def _map(jobs, workers: int):
    if workers <= 1:
        return [_episode(j) for j in jobs]
    with multiprocessing.get_context("spawn").Pool(workers) as pool:
        return pool.map(_episode, jobs)


def fit(seeds=FIT_SEEDS, planner: str = "lookahead", workers: int = 2) -> tuple[float, float]:
    """(fixed [J], per metre [J/m]) fitted to every pick of the episodes of `seeds`."""
    picks = [p for _, rows in _map([(s, planner, 0.0) for s in seeds], workers) for p in rows]
    d = np.array([p["travel_m"] for p in picks])
    e = np.array([p["energy_elec_j"] for p in picks])
    coef, _ = nnls(np.c_[np.ones_like(d), d], e)
    residual = e - (coef[0] + coef[1] * d)
    r2 = 1.0 - float(residual @ residual) / float(((e - e.mean()) ** 2).sum())
    print(
        f"{len(picks)} picks of seeds {seeds[0]}-{seeds[-1]} ({planner}): "
        f"E = {coef[0]:.1f} J + {coef[1]:.1f} J/m x d, R^2 {r2:.2f}; "
        f"median {np.median(e):.1f} J electrical, "
        f"{np.median([p['energy_mech_j'] for p in picks]):.1f} J mechanical, "
        f"d median {np.median(d):.3f} m"
    )
    return float(coef[0]), float(coef[1])


def tradeoff(
    prices=PRICES_EUR_PER_KWH, seeds=EVAL_SEEDS, planner: str = "lookahead", workers: int = 2
) -> list[dict]:
    """Per price: means over `seeds` of picked, profit, energy, its cost, the net profit."""
    jobs = [(s, planner, p) for p in prices for s in seeds]
    rows = [row for row, _ in _map(jobs, workers)]
    out = []
    print(
        f"{planner}, truth, 100 items x1, seeds {seeds[0]}-{seeds[-1]} (means)\n"
        "| price EUR/kWh | picked | profit EUR | energy kJ | J per pick | cost EUR | net EUR |\n"
        "|---|---|---|---|---|---|---|"
    )
    for k, price in enumerate(prices):
        mine = rows[k * len(seeds) : (k + 1) * len(seeds)]

        def mean(col, mine=mine):
            return statistics.fmean(float(r[col]) for r in mine)

        per_pick = mean("energy_elec_j") / max(mean("picked"), 1e-9)
        summary = {
            "price": price,
            "picked": mean("picked"),
            "profit": mean("profit_eur"),
            "energy_kj": mean("energy_elec_j") / 1e3,
            "cost": mean("energy_cost_eur"),
            "net": mean("net_profit_eur"),
        }
        out.append(summary)
        print(
            f"| {price:g} | {summary['picked']:.1f} | {summary['profit']:.2f} | "
            f"{summary['energy_kj']:.1f} | {per_pick:.0f} | {summary['cost']:.4f} | "
            f"{summary['net']:.2f} |"
        )
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim.experiments.energy_tradeoff")
    parser.add_argument("what", choices=["fit", "tradeoff"])
    parser.add_argument("--planner", default="lookahead")
    parser.add_argument("--workers", type=int, default=2, choices=range(1, 65), metavar="1..64")
    args = parser.parse_args(argv)
    if args.what == "fit":
        fit(planner=args.planner, workers=args.workers)
    else:
        tradeoff(planner=args.planner, workers=args.workers)
    return 0


if __name__ == "__main__":
    sys.exit(main())
