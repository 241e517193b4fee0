"""`sortsim train`: trains the `learned` pick-order policy on sortsim/PickOrder-v0.

The cross-entropy method over a linear slot scorer (`sim.evaluation.policy_training`), seeded:
the same seed writes the same weights. The default output is the policy the `learned` decision
manager ships with.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim train`."""
    parser.add_argument("--seed", type=int, default=0, help="seed of the search (default 0)")
    parser.add_argument("--iterations", type=int, default=None, help="cross-entropy iterations")
    parser.add_argument("--population", type=int, default=None, help="vectors per iteration")
    parser.add_argument("--belts", type=int, default=None, help="training belts per vector")
    parser.add_argument(
        "--out", type=Path, default=None, help="policy JSON (default: the shipped policy file)"
    )


def main(args: argparse.Namespace) -> int:
    """Train and write the policy."""
    from dataclasses import fields

    from planner.decision.managers.learned import POLICY_FILE
    from sim.errors import InvalidInput
    from sim.evaluation.policy_training import TrainingConfig, train
    from sim.results.outputs import check_output_file, write_atomic

    overrides = {
        f.name: getattr(args, f.name)
        for f in fields(TrainingConfig)
        if getattr(args, f.name, None) is not None
    }
    for name in ("iterations", "population", "belts"):
        value = overrides.get(name)
        if value is not None and not 1 <= value <= 100_000:
            raise InvalidInput(f"--{name}", "an integer 1..100000", value)
    out = Path(args.out) if args.out is not None else POLICY_FILE
    check_output_file(out, "--out", (".json",), "a JSON file")
    config = TrainingConfig(**overrides)

    def progress(iteration: int, best_now: float, best: float) -> None:
        if not args.quiet:
            print(
                f"iteration {iteration}/{config.iterations}: best of population "
                f"{best_now:.4f} EUR/belt, best so far {best:.4f}",
                flush=True,
            )

    policy, summary = train(config, progress)
    write_atomic(out, policy.to_json())
    print(
        f"trained on {summary['belts']} belts ({summary['episodes']} episodes, "
        f"{summary['cpu_s']:.0f} s CPU): {summary['train_profit_eur']:.4f} EUR/belt "
        f"(FIFO {summary['fifo_train_profit_eur']:.4f}); wrote {out}"
    )
    return 0
