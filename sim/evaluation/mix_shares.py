"""The materials' shares the flow generator gives, measured: long flows against the mix they
were set to, and how far a flow of a few hundred items strays from it (docs/episode.md, "The
feed in plant units").

    python -m sim.evaluation.mix_shares                         # the default flow
    python -m sim.evaluation.mix_shares --mix 0.40 0.35 0.25    # a mix by material

Each flow is the episode's (`EpisodeConfig.flow_config`: its stripes' Markov chains, the mix
matched by `sim.flow.mix`), its classes drawn as the flow generator draws them
(`sim.flow.generator.arrivals`, no physics and no item geometry): what enters the belt. For
`--long` items (100000 by default, the flow generator's largest) over `--seeds` seeds the shares of
the first seeds, their spread and the largest deviation from the mix are printed; for
`--short` items (600) over `--short-seeds` seeds, the standard deviation of each share and the
fraction of flows with every share within 2 points.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

LONG_ITEMS = 100000
SHORT_ITEMS = 600


def class_counts(config) -> np.ndarray:
    """The items of each material in the config's flow (catalogue order).

    Args:
        config: An `EpisodeConfig`.

    Returns:
        (materials,) counts.
    """
    from sim.flow.generator import arrivals

    flow = config.flow_config()
    _, _, classes = arrivals(flow, np.random.default_rng(flow.seed))
    return np.bincount(classes, minlength=config.materials.count)


def shares(mix: list[float] | None, items: int, seeds) -> np.ndarray:
    """The materials' shares of the flows of `seeds`.

    Args:
        mix: Shares by material (paper, plastic, aluminium), or None: the default flow.
        items: Items per flow (over the time that holds them at 6 per metre of belt).
        seeds: The seeds.

    Returns:
        (seeds, materials) shares.
    """
    from sim import config as episode_config
    from sim.flow.config import FlowConfig

    probe = episode_config.EpisodeConfig()
    mix_kwargs = episode_config.from_dict(_mix_table(mix)).mix_kwargs
    duration_s = items / (6.0 * probe.belt_speed_mps)
    rows = []
    for seed in seeds:
        flow = FlowConfig(n_items=items, duration_s=duration_s, seed=seed, **mix_kwargs)
        rows.append(_counts(flow, probe.materials.count))
    return np.array(rows) / items


def _mix_table(mix: list[float] | None) -> dict:
    """The config settings of a mix by material (paper, plastic, aluminium); {} for none."""
    if mix is None:
        return {}
    return {"flow": {"mix": dict(zip(("paper", "plastic", "aluminium"), mix, strict=True))}}


def _counts(flow, n_materials: int) -> np.ndarray:
    from sim.flow.generator import arrivals

    _, _, classes = arrivals(flow, np.random.default_rng(flow.seed))
    return np.bincount(classes, minlength=n_materials)


def main(argv: list[str] | None = None) -> int:
    """Print the measured shares against the mix."""
    from sim import config as episode_config

    parser = argparse.ArgumentParser(prog="python -m sim.evaluation.mix_shares")
    parser.add_argument("--mix", type=float, nargs=3, default=None, metavar="SHARE")
    parser.add_argument("--long", type=int, default=LONG_ITEMS, help="items of a long flow")
    parser.add_argument("--seeds", type=int, default=20, help="long flows (seeds 0..N-1)")
    parser.add_argument("--short", type=int, default=SHORT_ITEMS, help="items of a short flow")
    parser.add_argument("--short-seeds", type=int, default=200, help="short flows")
    args = parser.parse_args(argv)
    default = episode_config.EpisodeConfig()
    target = np.array(args.mix if args.mix is not None else default.material_shares)
    names = default.materials.names
    given = ", ".join(f"{n} {t:.4f}" for n, t in zip(names, target, strict=True))
    print(f"mix (stationary shares): {given}")
    config = default if args.mix is None else episode_config.from_dict(_mix_table(args.mix))
    transitions = np.round(np.array(config.mix_kwargs.get("transitions") or ()), 4).tolist()
    print(f"transitions: {transitions or 'the default'}")
    print(f"mean item mass: {1000 * config.mean_item_mass_kg:.2f} g")
    long = shares(args.mix, args.long, range(args.seeds))
    for seed, row in enumerate(long[:3]):
        dev = np.abs(row - target).max()
        print(f"seed {seed}, {args.long} items: {np.round(row, 4).tolist()} (max dev {dev:.4f})")
    print(
        f"{args.long}-item flows, {args.seeds} seeds: share sd "
        f"{np.round(long.std(axis=0), 4).tolist()}, largest deviation "
        f"{np.abs(long - target).max():.4f}"
    )
    short = shares(args.mix, args.short, range(args.short_seeds))
    sd = short.std(axis=0)
    within = np.mean(np.all(np.abs(short - target) <= 0.02, axis=1))
    print(
        f"{args.short}-item flows, {args.short_seeds} seeds: share sd "
        f"{np.round(sd, 4).tolist()}, every share within 2 points in {within:.0%}"
    )
    first = short[:20].mean(axis=0)
    print(
        f"the first 20 of them together: {np.round(first, 4).tolist()} (largest deviation "
        f"{np.abs(first - target).max():.4f})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
