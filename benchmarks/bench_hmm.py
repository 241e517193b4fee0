"""Cost of the stripe HMMs online: filtering + decoding a row of 5 stripes, one re-estimation.

Prints medians in microseconds and the command that reproduces them. Models are counted from a
synthetic labelled grid (the cost does not depend on the parameters' values).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from perception.hmm.online import OnlineConfig, OnlineStripeHmms
from perception.hmm.training import count_models


def _models(coupled: bool, rng):
    cls = rng.integers(1, 5, size=(400, 5))
    codes = rng.integers(1, 20, size=(400, 5))
    return count_models([cls], [codes], coupled=coupled), codes


def _median_us(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e6 * float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    args = parser.parse_args()
    rows = 300 if args.quick else 3000
    rng = np.random.default_rng(0)
    print(f"{'variant':<12}{'filter+decode [us/row]':>26}{'re-estimation [us]':>22}{'window':>8}")
    for coupled in (False, True):
        models, codes = _models(coupled, rng)
        online = OnlineStripeHmms(models, OnlineConfig(window=40, reestimate_every=0))
        it = iter(range(10**9))
        step_us = _median_us(lambda o=online, c=codes, i=it: o.step(c[next(i) % len(c)]), rows)
        for row in codes[:40]:
            online.step(row)
        reest_us = _median_us(online.reestimate, max(10, rows // 30))
        name = "coupled" if coupled else "independent"
        print(f"{name:<12}{step_us:>26.1f}{reest_us:>22.1f}{40:>8}")
    quick = " --quick" if args.quick else ""
    print(f"reproduce: .venv/bin/python benchmarks/bench_hmm.py{quick}")


if __name__ == "__main__":
    main()
