"""The top-level keys of an episode config, each declared once with its range or choices, help
and command-line option (`sim.config.fields`). `EpisodeSettings` holds them;
`sim.config.episode.EpisodeConfig` adds the tables and the rules between keys. Nothing heavy is
imported: the command line's parser is built from these fields (`sim.config.options`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from planner.decision.registry import COORDINATIONS, FLOW_PLANNERS, PLANNERS
from planner.motion.belt_speeds import SPEED_RANGE_MPS, SPEED_X1_MPS
from sim.config.fields import Range, setting
from sim.config.plant import MAX_ROBOTS
from sim.config.robots import RobotSpec
from sim.config.sections import ENERGY_PRICE, SPEED_TOLERANCE
from sim.flow.limits import LINE_MAX_ITEMS_PER_METRE, WORLD_LIMITS

PERCEPTIONS = ("camera", "truth")
CLASSIFIERS = ("fused", "features", "hmm")
ITEM_RIDINGS = ("path", "settled", "contact")
WORLDS = ("varied", "uniform")
MAX_ITEMS = 20000
DEFAULT_ITEMS = 100
"""`items` when neither it nor an `[infeed]` rate is given."""
DEFAULT_SPEED_FACTOR = 1.0
"""`speed_factor` when neither it nor `[belt] speed_mps` is given."""
ITEM_CLASSIFIER_MIN_CONFIDENCE = 0.9
"""The confidence rule's threshold of the item classifier's modes (`fused`, `features`) when a
config sets none (`sim.sensing.confidence`)."""
_X1 = SPEED_X1_MPS
_SECONDS = Range(1.0, 36000.0, "1..36000 s")


def default_min_confidence(perception: str, classifier: str) -> float:
    """The confidence rule's threshold, in [0, 1], of an episode whose config sets none:
    `ITEM_CLASSIFIER_MIN_CONFIDENCE` for the camera's item classifier modes, 0 (every item
    offered) for the stripe HMMs alone and for truth perception."""
    if perception != "camera" or classifier == "hmm":
        return 0.0
    return ITEM_CLASSIFIER_MIN_CONFIDENCE


def belt_speed_mps(speed_factor: float) -> float:
    """Belt speed [m/s] of a speed factor (x1 = 0.185 m/s)."""
    return SPEED_X1_MPS * float(speed_factor)


def _world(name: str) -> Any:
    """A number overriding the `world` preset's (`sim.flow.world.WorldVariation`, which
    checks its range)."""
    high = WORLD_LIMITS[name]
    return setting(
        range=Range(0.0, high, f"a number in [0, {high:g}]", checked_by="sim.flow.world"),
        number=True,
        option="--" + name.replace("_", "-"),
        help=f"override the world preset's {name}, {{allowed}} (docs/world.md)",
    )


@dataclass(frozen=True)
class EpisodeSettings:
    """The top-level keys of an episode config (described with their units and ranges in
    `sim.config`'s docstring and docs/settings.md); checked by `EpisodeConfig`."""

    seed: int = setting(
        0,
        range=Range(0, 2**63 - 1, "0..2^63-1", integer=True),
        option="--seed",
        help="the episode's seed, {allowed}: the flow, the world's variation and every random "
        "draw; the same seed and config give the same CSVs (default {default})",
    )
    items: int = setting(
        DEFAULT_ITEMS,
        range=Range(1, MAX_ITEMS, f"1..{MAX_ITEMS}", integer=True),
        option="--items",
        help=f"items dropped on the belt, {{allowed}}, at most {LINE_MAX_ITEMS_PER_METRE:g} per "
        "metre of belt travel over the flow (default {default})",
    )
    speed_factor: float = setting(
        DEFAULT_SPEED_FACTOR,
        range=Range(
            SPEED_RANGE_MPS[0] / _X1,
            1.5,
            f"{SPEED_RANGE_MPS[0] / _X1:.3f}..1.5 (belt {SPEED_RANGE_MPS[0]}..{SPEED_RANGE_MPS[1]}"
            f" m/s at {_X1} m/s per x1)",
            slack=(1e-9 / _X1, (SPEED_RANGE_MPS[1] + SPEED_TOLERANCE) / _X1 - 1.5),
        ),
        option="--speed-factor",
        help=f"belt speed over x1 = {_X1} m/s: any factor from {{lo:.2f}} to {{hi:g}} "
        f"({SPEED_RANGE_MPS[0]}..{SPEED_RANGE_MPS[1]} m/s, the conveyor's range; the thesis "
        "ran 1, 1.2 and 1.5) (default {default:g})",
    )
    planner: str = setting(
        "qlearning",
        option="--planner",
        metavar="NAME|module:Class",
        help=f"decision manager: {' | '.join((*PLANNERS, *FLOW_PLANNERS))}, or module:Class of "
        "your own "
        "(default {default})",
    )
    perception: str = setting(
        "camera",
        choices=PERCEPTIONS,
        option="--perception",
        help="camera (default): rendered camera frames, items classed by --classifier; truth: "
        "every item past the camera line where it is, its true class certain (no rendering)",
    )
    duration_s: float = setting(
        90.0,
        range=_SECONDS,
        option="--duration",
        help="seconds over which the items arrive, {lo:g}..{hi:g} (default {default:g})",
    )
    horizon_s: float | None = setting(
        range=_SECONDS,
        option="--horizon",
        metavar="S",
        help="end the run at S simulated seconds, {lo:g}..{hi:g}, counting the items still on "
        "the belt and those not yet arrived (default: once every item has arrived and left the "
        "belt)",
    )
    observation_period_s: float = setting(0.5, range=Range(0.05, 5.0, "0.05..5 s"))
    item_riding: str = setting("path", choices=ITEM_RIDINGS)
    energy_price_eur_per_kwh: float = setting(
        0.0,
        range=ENERGY_PRICE,
        option="--energy-price",
        metavar="EUR_PER_KWH",
        help="price of the motors' electrical energy, {lo:g}..{hi:g}; > 0: every planner nets "
        "it (default {default:g})",
    )
    min_class_confidence: float | None = setting(
        range=Range(0.0, 1.0, "a probability in [0, 1]"),
        option="--min-confidence",
        metavar="P",
        help="leave on the belt an item whose most probable class has a posterior below P, "
        "{lo:g}..{hi:g}; 0: every item may be picked (default: the classifier's own, "
        f"{ITEM_CLASSIFIER_MIN_CONFIDENCE:g} for fused and features, 0 for hmm and truth)",
    )
    classifier: str = setting(
        "fused",
        choices=CLASSIFIERS,
        option="--classifier",
        help="camera items' class: fused (features x stripe HMMs, default), features, hmm "
        "(the thesis's path)",
    )
    depth_noise: bool = setting(True, boolean=True)
    world: str = setting(
        "varied",
        choices=WORLDS,
        option="--world",
        help="varied: item sizes, shapes, colours and gaps vary as on a real belt; uniform: "
        "every item its catalogue type's (default {default}; docs/world.md)",
    )
    size_jitter: float | None = _world("size_jitter")
    crushed_share: float | None = _world("crushed_share")
    crumpled_share: float | None = _world("crumpled_share")
    folded_share: float | None = _world("folded_share")
    hue_jitter_deg: float | None = _world("hue_jitter_deg")
    colour_jitter: float | None = _world("colour_jitter")
    label_share: float | None = _world("label_share")
    min_gap_m: float | None = _world("min_gap_m")
    overlap_share: float | None = _world("overlap_share")
    overlap_depth_m: float | None = _world("overlap_depth_m")
    robots: tuple[RobotSpec, ...] = setting(
        (RobotSpec(),),
        range=Range(
            1, MAX_ROBOTS, f"1..{MAX_ROBOTS}", integer=True, checked_by="sim.config.robots"
        ),
        option="--robots",
        metavar="N",
        help="IRB 360s in series over the belt, {lo}-{hi}: a sorting line (default 1; "
        "docs/line.md)",
    )
    coordination: str = setting(
        "coordinated",
        choices=COORDINATIONS,
        option="--coordination",
        help="a line's robots: each on its own, or the upstream one leaving what a downstream "
        "one can take (default {default})",
    )
    catalogue: str = setting(
        "",
        option="--catalogue",
        metavar="TOML",
        help="item catalogue: its materials (one bin each), values and item types "
        "(default sim/data/items.toml: paper, plastic, aluminium; docs/materials.md)",
    )


WORLD_NUMBERS = tuple(name for name in WORLD_LIMITS if name in EpisodeSettings.__dataclass_fields__)
"""Keys overriding one number of the `world` preset (`sim.flow.world.WorldVariation`'s fields)."""
