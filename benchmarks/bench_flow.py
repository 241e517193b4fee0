"""Flow generator and ground-truth grid: speed, and agreement with the configured statistics.

Generates 20 000 items (x1, 1.67 items/s) with the default stripe priors and class transition
matrix, and prints: generation speed [items/s], ground-truth grid time [ms per row], chi-square
p-values and largest absolute deviations of the stripe frequencies and of each transition row.

Run: `.venv/bin/python benchmarks/bench_flow.py [--quick]`
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy import stats

from sim.flow.catalogue import load_catalogue
from sim.flow.config import FlowConfig
from sim.flow.generator import generate_flow
from sim.flow.ground_truth import flow_truth


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true", help="4 000 items instead of 20 000")
    args = parser.parse_args()
    n = 4_000 if args.quick else 20_000
    catalogue = load_catalogue()
    config = FlowConfig(n_items=n, duration_s=n / (150 / 90), seed=0)
    runs = []
    for _ in range(3):
        start = time.perf_counter()
        flow = generate_flow(config, catalogue)
        runs.append(time.perf_counter() - start)
    print(f"flow generation: {n / np.median(runs):.0f} items/s (median of 3, {n} items, x1)")
    start = time.perf_counter()
    classes, _ = flow_truth(flow, catalogue)
    elapsed = time.perf_counter() - start
    rows = len(classes)
    print(f"ground-truth grid: {1e3 * elapsed / rows:.3f} ms per row ({rows} rows x 5 stripes)")

    counts = np.bincount(flow.stripe, minlength=5)
    priors = np.asarray(config.stripe_priors)
    p_value = stats.chisquare(counts, priors * n).pvalue
    deviation = np.abs(counts / n - priors).max()
    print(f"stripes: chi-square p = {p_value:.3f}, max |freq - prior| = {deviation:.4f}")
    transitions = np.zeros((3, 3))
    for stripe in range(5):
        sequence = flow.class_id[flow.stripe == stripe] - 2
        np.add.at(transitions, (sequence[:-1], sequence[1:]), 1)
    names = ("paper", "plastic", "aluminium")
    for name, row, probs in zip(names, transitions, config.transitions, strict=True):
        p_value = stats.chisquare(row, np.asarray(probs) * row.sum()).pvalue
        deviation = np.abs(row / row.sum() - probs).max()
        print(
            f"transitions from {name}: chi-square p = {p_value:.3f}, "
            f"max |freq - P| = {deviation:.4f} ({int(row.sum())} transitions)"
        )
    print("command: .venv/bin/python benchmarks/bench_flow.py" + (" --quick" if args.quick else ""))


if __name__ == "__main__":
    main()
