"""`sortsim advise`: the sweep a purchase needs, and its answer.

From a plant's episode config (its belt, feed, mix, prices and `[economics]`), runs lines of
1-4 robots at each belt speed through truth and the camera as one sweep into `--out` (the
runs stay there for `sortsim report`), in rounds of seeds: 3 first, then more (5, 8, ... up to
`--max-seeds`) while a line that could change the answer is still open. Then writes
`advice.md` there and prints it: every line's targets with their 95 % intervals, profit per
hour, payback and verdict, the cheapest line that meets the targets with 95 % confidence and
the runner-up (`sim.experiments.reporting.advice`), and the time it took.

The plant's config may not set the robots (a count is replaced by the sweep's; a table of
robots is refused), and its `perception` and belt speed are the sweep's axes. Every option and
the whole grid are checked before the first episode; the folder takes the sweep's rules (a
folder of another sweep, or of other code, is refused).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from sim.errors import InvalidInput

SEED_ROUNDS = (3, 5, 8, 12, 20, 30)
"""Seeds a line has after each round (a round adds seeds only while the answer is open)."""
DEFAULT_TARGETS = "recovery=0.9,purity=0.95"
PERCEPTIONS = ("truth", "camera")
MAX_ROBOTS = 4


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim advise`."""
    parser.add_argument("--config", type=Path, required=True, help="the plant's episode TOML")
    parser.add_argument("--out", type=Path, required=True, help="the sweep's folder")
    parser.add_argument(
        "--targets",
        default=DEFAULT_TARGETS,
        help="kind[.material]=level, comma-separated: recovery, purity (default "
        f"{DEFAULT_TARGETS}: every material 90 %% recovered, every bin 95 %% pure)",
    )
    parser.add_argument("--robots", default="1,2,3,4", help="robot counts (1-4), comma-separated")
    parser.add_argument(
        "--belt-speeds",
        default=None,
        metavar="M/S",
        help="belt speeds [m/s], comma-separated (default: the config's)",
    )
    parser.add_argument(
        "--perception", default="truth,camera", help="truth, camera or both (the camera decides)"
    )
    parser.add_argument(
        "--max-seeds", type=int, default=8, help="most seeds a line gets (3-30, default 8)"
    )
    parser.add_argument("--workers", type=int, default=None, help="local worker processes")


def _numbers(text: str, field: str, allowed: str, kind=float) -> list:
    try:
        values = [kind(v) for v in text.split(",")]
    except ValueError:
        raise InvalidInput(field, allowed, text) from None
    if len(set(values)) != len(values):
        raise InvalidInput(field, allowed, text)
    return values


def _options(args: argparse.Namespace, config) -> dict:
    """The sweep's axes and the targets from the options, each refused in one line."""
    from sim.experiments.reporting.advice import parse_targets

    robots = _numbers(args.robots, "--robots", f"distinct counts 1..{MAX_ROBOTS}", int)
    if not all(1 <= r <= MAX_ROBOTS for r in robots):
        raise InvalidInput("--robots", f"distinct counts 1..{MAX_ROBOTS}", args.robots)
    speeds = [config.belt_speed_mps]
    if args.belt_speeds is not None:
        speeds = _numbers(args.belt_speeds, "--belt-speeds", "distinct speeds in m/s", float)
    perceptions = args.perception.split(",")
    if not perceptions or any(p not in PERCEPTIONS for p in perceptions):
        raise InvalidInput("--perception", "truth, camera or truth,camera", args.perception)
    if not SEED_ROUNDS[0] <= args.max_seeds <= SEED_ROUNDS[-1]:
        raise InvalidInput("--max-seeds", f"{SEED_ROUNDS[0]}..{SEED_ROUNDS[-1]}", args.max_seeds)
    targets = parse_targets(args.targets, config.materials.names)
    return dict(robots=robots, speeds=speeds, perceptions=perceptions, targets=targets)


def sweep_data(plant: dict, options: dict, seeds: int, name: str) -> dict:
    """The sweep's TOML data: the plant's config as its base, robots x perception as its
    variants, the belt speeds as its axis."""
    base = {k: v for k, v in plant.items() if k not in ("robots", "perception", "speed_factor")}
    belt = {k: v for k, v in base.get("belt", {}).items() if k != "speed_mps"}
    base = base | {"belt": belt} if belt else {k: v for k, v in base.items() if k != "belt"}
    variants = [
        {"name": f"{r} robot{'s' * (r > 1)}, {p}", "robots": r, "perception": p}
        for p in options["perceptions"]
        for r in options["robots"]
    ]
    sweep = {"name": name, "belt_speeds_mps": options["speeds"]}
    sweep["planners"] = [base.pop("planner", "qlearning")]
    if "items" in base:  # a count rather than a feed rate: the sweep's items axis
        sweep["items"] = [base.pop("items")]
    return {"sweep": sweep | {"seeds": seeds}, "base": base, "variants": variants}


def main(args: argparse.Namespace) -> int:
    """Check everything, run the rounds of seeds, write and print the answer."""
    from sim import config as episode_config
    from sim.experiments import sweep_config

    plant = episode_config.read_toml(args.config)
    if isinstance(plant.get("robots"), list):
        raise InvalidInput("robots", "a count or nothing (advise sets the robots)", "tables")
    config = episode_config.load(args.config)
    options = _options(args, config)
    if args.workers is not None and not 1 <= args.workers <= 256:
        raise InvalidInput("--workers", "an integer 1..256", args.workers)
    name = f"advise_{args.config.stem}"
    where = str(args.config)
    full = sweep_config.from_dict(sweep_data(plant, options, args.max_seeds, name), where)
    return _rounds(args, full, options, config.materials.names)


def _cpu_s() -> float:
    """CPU time of this process and its finished workers [s]."""
    times = os.times()
    return times.user + times.system + times.children_user + times.children_system


def _rounds(args, full, options: dict, materials: tuple[str, ...]) -> int:
    """Rounds of seeds until the answer is decided or the seeds run out; the answer written."""
    from sim.cli import sweep as sweep_cli
    from sim.experiments import sweep_config
    from sim.experiments.reporting import advice
    from sim.results import outputs

    start_wall, start_cpu = time.perf_counter(), _cpu_s()
    rounds = [n for n in SEED_ROUNDS if n < args.max_seeds] + [args.max_seeds]
    run_args = argparse.Namespace(
        out=args.out, workers=args.workers, ray=None, mix_code=False, seeds=None
    )
    sweep_cli.check_rendering(full)
    results = []
    for seeds in rounds:
        round_config = sweep_config.first_seeds(full, seeds)
        sweep_cli.run_locked(run_args, round_config)
        rows = outputs.read_rows(args.out / "episodes.csv")
        results = advice.line_results(rows, options["targets"], materials)
        if advice.decided(results):
            break
    wall, cpu = time.perf_counter() - start_wall, _cpu_s() - start_cpu
    text = "\n\n".join(
        [
            f"# Advice: {args.config}",
            f"Targets: {args.targets}; lines judged through "
            f"{advice.deciding_perception(results)}, 95 % Student-t intervals over the seeds.",
            advice.table(results),
            advice.recommendation(results, options["targets"]),
            f"{sum(r.seeds for r in results)} episodes in {args.out}; this command took "
            f"{wall / 60:.1f} min wall, {cpu / 60:.1f} CPU-min (its workers included). "
            f"What each added robot earns: `sortsim report {args.out}`.",
        ]
    )
    (args.out / "advice.md").write_text(text + "\n", encoding="utf-8")
    print(text)
    return 0
