"""Configuration of one episode: a frozen, eagerly validated dataclass read from TOML.

Every key a TOML file may hold is a field below; unknown keys, wrong types, values out of
range and malformed TOML are refused with one line naming the key and the file
(`InvalidInput`, exit code 2) before anything runs. Command-line options override the file.

Files are read at the edge, never in the dataclass's validation: `load`, `from_dict` (and
`read_config_file`, `EpisodeConfig.build`, `EpisodeConfig.replace` with a new `catalogue`)
read the item catalogue the `catalogue` key names and hand it to the config as a
`CatalogueFile` (`catalogue_file`: the key it was read for, its content digest, the
`Catalogue`). The config keeps the key (`catalogue`, what a manifest records) and the
catalogue it was validated against, so `EpisodeConfig()` (the built-in catalogue, read once
per process) and `config.replace(...)` need no file, a config pickles whole to a sweep's worker
process (which then reads no file either) and two configs compare equal by what they run with
(every other setting, the catalogue's key and its content digest; the `Catalogue` object and
`where` are left out). A `catalogue_file` that was not read for the `catalogue` key (say
`dataclasses.replace(config, catalogue=...)`, which reads nothing) is refused in one line
naming `catalogue`. Frozen dataclasses and no validation library: the checks are a few lines
each (`sim.checks`), and the refusals keep the project's one-line form.

TOML layout (every key optional; defaults are the headline episode)::

    seed = 0
    items = 100
    speed_factor = 1.0          # belt speed = 0.185 m/s x factor, inside 0.135..0.277 m/s;
                                # or [belt] speed_mps (below), not both
    planner = "qlearning"       # qlearning | rollout | lookahead | proximity | fifo | greedy
                                # | random | oracle | module:Class
    perception = "camera"       # camera | truth
    duration_s = 90.0           # items arrive over this time [s]
    horizon_s = 90.0            # the run ends at this time [s], the items still on the belt
                                # and those not yet arrived counted (left_on_belt,
                                # not_arrived); unset: once every item has arrived and left
                                # the belt
    observation_period_s = 0.5  # one grid row per period [s]
    item_riding = "path"        # path | settled | contact (see sim/cell/riding.py)
    energy_price_eur_per_kwh = 0.0  # > 0: every planner nets each pick's motor energy cost
    min_class_confidence = 0.9  # 0..1: an item whose most probable class is less probable is
                                # left on the belt (sim/sensing/confidence.py); 0: none is;
                                # unset: the classifier's own (0.9 fused and features, 0 hmm
                                # and truth)
    classifier = "fused"        # camera items' class: fused | features | hmm (the thesis's)
    depth_noise = true          # the stereo camera's depth error (sim/cell/depth_noise.py)
    world = "varied"            # varied | uniform: how items vary (sim/flow/world.py,
                                # docs/world.md); the numbers below override the preset's
    size_jitter = 0.15          # size factors in [1 - j, 1 + j] per dimension
    crushed_share = 0.25        # cans and bottles crushed
    crumpled_share = 0.2        # paper sheets crumpled
    folded_share = 0.15         # A4 sheets folded
    hue_jitter_deg = 8.0        # colour: hue +- [deg]
    colour_jitter = 0.12        # colour: saturation and value +- (relative)
    label_share = 0.6           # round containers with a printed label in a second colour
    min_gap_m = 0.0             # least gap between items [m] (uniform: 0.005)
    overlap_share = 0.1         # flat-sided items allowed to lie partly over a flat neighbour
    overlap_depth_m = 0.02      # how far over it [m]
    robots = 1                  # IRB 360s in series over the belt, 1..4 (a sorting line) at
                                # the default spacing, or a [[robots]] table per robot (below,
                                # after the tables)
    coordination = "coordinated"  # a line's: independent | coordinated
                                # (planner/decision/line_coordination.py)
    catalogue = ""              # item catalogue TOML (its [[material]] entries name the
                                # materials, one bin each); "": sim/data/items.toml (the
                                # thesis's paper, plastic, aluminium). Relative paths are
                                # taken from the directory the command runs in.
    [values]                    # EUR per item of a material, or of one item type (which then
    paper = 0.22                # overrides its material's in the profit); unset: the
    plastic = 0.25              # catalogue's value_eur (thesis table 3.3 by default)
    aluminium = 0.27
    per_kg = { aluminium = 1.2 }   # EUR/kg instead (a name has one or the other): an item
                                # is worth its own mass x the price
    [flow]                      # the class mix of the flow (default: the thesis's for its
    class_priors = [0.29, 0.36, 0.35]   # three materials, equal shares otherwise); one entry
    transitions = [[0.46, 0.30, 0.24],  # per material in the catalogue's order
                   [0.22, 0.50, 0.28],
                   [0.20, 0.28, 0.52]]
    stripe_priors = [0.16, 0.22, 0.24, 0.22, 0.16]
    mix = { paper = 0.40, plastic = 0.35, aluminium = 0.25 }  # or the mix as shares: by
                                # material (every one named), or by base item type of the
                                # catalogue (mix_types = { paper_sheet_a4 = 0.1, ... }, types
                                # not named not drawn), not both, nor with class_priors: the
                                # transitions are matched to the shares (sim/flow/mix.py)
    [qlearning]                 # the thesis's Q-learning (also read by rollout); seeded by seed
    gamma = 0.9
    iterations = 50
    batch_rows = 20
    objective = "value_over_distance"   # | value_only (d = 1) | distance_only (v = 1)
    [robot]                     # every robot's defaults (a [[robots]] table's own key wins)
    pick_pause_s = 0.0          # extra dwell after each pick / place, 0..2 s (thesis: ~0.5 s
    place_pause_s = 0.0         # each)
    idle_sleep = true           # an idle robot sleeps in MuJoCo until its next pick
                                # (sim/cell/idle_sleep.py); false: the physics to the bit
                                # as before it
    [video]
    fps = 10.0                  # frames per simulated second
    width = 640
    height = 360
    [camera]                    # the belt camera's frames [px], 16:9 like its calibration
    width = 640                 # 384..1920, a multiple of 16 (the calibration is scaled to it)
    height = 360                # width x 9/16
    per_robot = false           # a line: each robot its own belt camera upstream of its reach,
                                # their tracks fused (docs/line.md); false: the one camera
    [cup]                       # the vacuum cup
    diameter_m = 0.06           # lip diameter 0.02..0.12 m (recompiles the cell's model);
                                # unset: 0.06 for one robot, 0.05 for a line (docs/line.md)
    vacuum_pa = 80000.0         # vacuum below atmosphere, 1000..101325 Pa; holds area x vacuum
    [belt]
    speed_mps = 0.2             # belt speed [m/s], 0.135..0.277, instead of speed_factor
    length_m = 4.5              # 4..20 m from the infeed; the discharge end moves (recompiles)
    width_m = 0.8               # 0.4..1.2 m; the stripes, bins, camera rig follow (recompiles)
    infeed_hold = true          # an item that would drop into one already on the belt is held
                                # back (sim/episode/infeed.py); false: every result to the bit
                                # as before it
    [hmm]                       # camera perception's stripe HMMs
    coupled = false             # true: each stripe's transitions use its neighbour stripes'
                                # states at t-1 (thesis 1.3); false: five independent HMMs
    [economics]                 # what a robot costs: the money columns only (an assumption
    robot_capital_eur = 75000.0  # for one delta robot cell; set the plant's own figures)
    robot_life_years = 10.0
    hours_per_year = 4000.0
    robot_maintenance_eur_per_year = 3000.0
    energy_price_eur_per_kwh = 0.2   # the top-level key, given here instead (either place)
    [infeed]                    # the feed in plant units instead of items (one key of three;
    items_per_m = 18.0          # sim/flow/feed_rate.py): items per metre of belt, or
    # items_per_s = 3.6         # items per second, or kilograms per hour at the catalogue's
    # kg_per_h = 250.0          # mean item mass under the mix; items = the rate over
                                # duration_s (18 x belt speed x duration_s), rounded

The robots one by one, instead of `robots = N` (sim/episode/line_robots.py, docs/line.md;
`--robots N` and a sweep's `robots = N` give N robots at the default spacing, robot k keeping
robot k's pauses)::

    [[robots]]                  # the first robot, upstream
    x_m = 0.0                   # its base along the belt [m]; for every robot or none (then
                                # 0, 1.8, 3.6, ...): first >= 0, >= 1.8 m apart, last <= 15.5
    materials = ["aluminium"]   # what it picks (items by their most probable material);
                                # omitted: every material. Each material by some robot
    pick_pause_s = 0.5          # this robot's own pauses and idle_sleep (omitted: [robot]'s)
    [[robots]]
    x_m = 2.2

Whatever the form, the config holds one tuple of robots (`EpisodeConfig.robots`, one
`RobotSpec` each) and writes one array of tables (`to_dict`, a run's manifest.json)::

    robots = [{x_m = 0.0, materials = ["aluminium"], pick_pause_s = 0.5, place_pause_s = 0.0,
               idle_sleep = true}, {x_m = 2.2, pick_pause_s = 0.0, ...}]
"""

from __future__ import annotations

import dataclasses
import functools
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from perception.codes import Materials
from planner.decision.line_coordination import COORDINATIONS
from planner.decision.registry import ALLOWED as ALLOWED_PLANNERS
from planner.decision.registry import check_planner
from planner.decision.robot_materials import class_ids_of
from planner.motion.belt_speeds import SPEED_RANGE_MPS, SPEED_TOLERANCE_MPS, SPEED_X1_MPS
from sim.cell.camera import FRAME_SIZE
from sim.checks import check, is_integer, is_number
from sim.episode.line_robots import (
    MAX_PAUSE_S,
    MAX_ROBOTS,
    RobotSpec,
    check_count,
    check_robots,
    resized,
    robot_section,
    robot_specs,
)
from sim.errors import InvalidInput, RefusedInput
from sim.flow import feed_rate
from sim.flow import mix as flow_mix
from sim.flow.catalogue import DEFAULT_CATALOGUE, MASS_RANGE_KG, Catalogue, load_catalogue
from sim.flow.config import (
    BELT_WIDTH_M,
    BELT_WIDTH_RANGE_M,
    LINE_MAX_ITEMS_PER_METRE,
    MAX_ITEMS_PER_METRE,
    STRIPE_WIDTH,
    FlowConfig,
    default_transitions,
)
from sim.flow.feed_rate import FEED_KEYS
from sim.flow.generator import EDGE_MARGIN_M
from sim.flow.world import WORLD_LIMITS, WorldVariation, check_varied
from sim.model.line_model import MAX_LAST_X_M
from sim.model.scene_edits import (
    BELT_LENGTH_M,
    BELT_LENGTH_RANGE_M,
    CUP_DIAMETER_RANGE_M,
    CellSettings,
    default_cup_diameter_m,
)
from sim.results.economics import robot_cost_per_h
from sim.sensing.confidence import default_min_confidence

BELT_SPEED_X1_MPS = SPEED_X1_MPS
BELT_SPEED_RANGE_MPS = SPEED_RANGE_MPS
# x1.5 is the belt's top speed: 0.2775 m/s rounds to the conveyor's 0.277 m/s.
_SPEED_TOLERANCE_MPS = SPEED_TOLERANCE_MPS + 1e-12  # the belt's own check, to the bit
PERCEPTIONS = ("camera", "truth")
CLASSIFIERS = ("fused", "features", "hmm")
ITEM_RIDINGS = ("path", "settled", "contact")
OBJECTIVES = ("value_over_distance", "value_only", "distance_only")
WORLDS = ("varied", "uniform")
WORLD_NUMBERS = tuple(f.name for f in dataclasses.fields(WorldVariation))
"""Keys overriding one number of the `world` preset (`WorldVariation`'s fields)."""
MAX_ITEMS = 20000
MAX_ENERGY_PRICE = 1e6
"""Highest energy price accepted [EUR/kWh] (far above any tariff: a stress test's price)."""
MAX_VALUE_EUR = 1e6
"""Highest value of an item [EUR]."""
DEFAULT_ITEMS = 100
"""`items` when neither it nor an `[infeed]` rate is given."""
DEFAULT_SPEED_FACTOR = 1.0
"""`speed_factor` when neither it nor `[belt] speed_mps` is given."""
MIN_FEED_RATE = 0.01
"""Smallest feed rate of an `[infeed]` key (items/m, items/s, kg/h)."""
MAX_ITEMS_PER_S = LINE_MAX_ITEMS_PER_METRE * 1.5 * SPEED_X1_MPS
"""Fastest item rate: the densest belt at the belt's top speed (x1.5) [items/s]."""
MAX_KG_PER_H = round(MAX_ITEMS_PER_S * feed_rate.SECONDS_PER_HOUR * MASS_RANGE_KG[1], 3)
"""Largest mass rate: the fastest item rate of the heaviest items a catalogue may hold
[kg/h] (the catalogue's mean item mass decides: the belt's loading is checked with it)."""


@dataclass(frozen=True)
class Range:
    """The documented range of one numeric config key: what loading accepts (`allows`) and
    what its refusal says (`allowed`). `RANGES` holds every numeric key's; the checks below use
    it, and the tests walk both ends of each and just outside them.

    Attributes:
        lo: Smallest value [the key's unit].
        hi: Largest value (excluded when `hi_open`).
        allowed: The refusal's words (`0.05..5 s`).
        integer: Only ints (not a float of integer value, not a bool).
        multiple: An int's step (a multiple of it).
        hi_open: `hi` itself is out of range: [lo, hi).
        slack: How far below `lo` and above `hi` a value is still taken, for the rounding of
            another unit (the belt's speed, checked in m/s) [the key's unit].
        entries: "": one number; "list": a list of them (probabilities summing to 1);
            "rows": a list of such lists; "table": a table of them by name (shares summing
            to 1).
        checked_by: The module whose check enforces it, when not this one's.
    """

    lo: float
    hi: float
    allowed: str
    integer: bool = False
    multiple: int = 1
    hi_open: bool = False
    slack: tuple[float, float] = (0.0, 0.0)
    entries: str = ""
    checked_by: str = ""

    def allows(self, value: object) -> bool:
        """Whether `value` is inside the range.

        Args:
            value: As a config file gives it.

        Returns:
            True for a number of the right kind (an int when `integer`) within the ends.
        """
        if not (is_integer(value) if self.integer else is_number(value)):
            return False
        # Ints compared as ints: 2**63 - 1 + 0.0 would round to 2**63.
        lo = self.lo - self.slack[0] if self.slack[0] else self.lo
        hi = self.hi + self.slack[1] if self.slack[1] else self.hi
        if not (lo <= value and (value < hi if self.hi_open else value <= hi)):
            return False
        return not self.integer or value % self.multiple == 0

    def check(self, key: str, value: object, where: str | None = None) -> None:
        """Refuse `value` of `key` in one line unless it is inside the range.

        Args:
            key: The key as the user names it.
            value: Its value.
            where: The file it came from, if any.
        """
        check(self.allows(value), key, self.allowed, value, where)


def _share(high: float) -> Range:
    return Range(0.0, high, f"a number in [0, {high:g}]", checked_by="sim.flow.world")


_X1 = SPEED_X1_MPS
_PROBABILITIES = "probabilities, each in [0, 1], summing to 1"
RANGES: dict[str, Range] = {
    "seed": Range(0, 2**63 - 1, "0..2^63-1", integer=True),
    "items": Range(1, MAX_ITEMS, f"1..{MAX_ITEMS}", integer=True),
    "speed_factor": Range(
        SPEED_RANGE_MPS[0] / _X1,
        1.5,
        f"{SPEED_RANGE_MPS[0] / _X1:.3f}..1.5 (belt {SPEED_RANGE_MPS[0]}..{SPEED_RANGE_MPS[1]} "
        f"m/s at {_X1} m/s per x1)",
        slack=(1e-9 / _X1, (SPEED_RANGE_MPS[1] + _SPEED_TOLERANCE_MPS) / _X1 - 1.5),
    ),
    "duration_s": Range(1.0, 36000.0, "1..36000 s"),
    "horizon_s": Range(1.0, 36000.0, "1..36000 s"),
    "observation_period_s": Range(0.05, 5.0, "0.05..5 s"),
    "energy_price_eur_per_kwh": Range(0.0, MAX_ENERGY_PRICE, f"0..{MAX_ENERGY_PRICE:g} EUR/kWh"),
    "min_class_confidence": Range(0.0, 1.0, "a probability in [0, 1]"),
    **{name: _share(high) for name, high in WORLD_LIMITS.items()},
    "robots": Range(
        1, MAX_ROBOTS, f"1..{MAX_ROBOTS}", integer=True, checked_by="sim.episode.line_robots"
    ),
    "robot.pick_pause_s": Range(
        0.0, MAX_PAUSE_S, f"0..{MAX_PAUSE_S:g} s", checked_by="sim.episode.line_robots"
    ),
    "robot.place_pause_s": Range(
        0.0, MAX_PAUSE_S, f"0..{MAX_PAUSE_S:g} s", checked_by="sim.episode.line_robots"
    ),
    "robots[0].x_m": Range(
        0.0, MAX_LAST_X_M, f"0..{MAX_LAST_X_M:g} m", checked_by="sim.episode.line_robots"
    ),
    "values.<material>": Range(0.0, MAX_VALUE_EUR, f"0..{MAX_VALUE_EUR:g} EUR"),
    "values.per_kg.<material>": Range(0.0, MAX_VALUE_EUR, f"0..{MAX_VALUE_EUR:g} EUR/kg"),
    "flow.class_priors": Range(0.0, 1.0, _PROBABILITIES, entries="list", checked_by="sim.flow"),
    "flow.transitions": Range(0.0, 1.0, _PROBABILITIES, entries="rows", checked_by="sim.flow"),
    "flow.stripe_priors": Range(0.0, 1.0, _PROBABILITIES, entries="list", checked_by="sim.flow"),
    "flow.mix": Range(0.0, 1.0, "shares in [0, 1] summing to 1", entries="table"),
    "flow.mix_types": Range(0.0, 1.0, "shares in [0, 1] summing to 1", entries="table"),
    "qlearning.gamma": Range(0.0, 1.0, "[0, 1)", hi_open=True),
    "qlearning.iterations": Range(1, 10000, "1..10000", integer=True),
    "qlearning.batch_rows": Range(1, 1000, "1..1000", integer=True),
    "video.fps": Range(1.0, 60.0, "1..60"),
    "video.width": Range(64, 1920, "64..1920, a multiple of 8", integer=True, multiple=8),
    "video.height": Range(64, 1920, "64..1920, a multiple of 8", integer=True, multiple=8),
}
"""Every numeric key of a config file with its documented range (sections' keys dotted; the
camera's, cup's and belt's follow their sections below). `checked_by` names the module whose
check enforces a key checked elsewhere."""


def belt_speed_mps(speed_factor: float) -> float:
    """Belt speed of a speed factor (x1 = 0.185 m/s).

    Args:
        speed_factor: Belt speed over x1.

    Returns:
        The belt speed [m/s].
    """
    return BELT_SPEED_X1_MPS * float(speed_factor)


@functools.lru_cache(maxsize=16)
def _catalogue_at(path: str, mtime_ns: int, size: int) -> Catalogue:
    return load_catalogue(path)


def episode_catalogue(path: str) -> Catalogue:
    """The item catalogue of a config's `catalogue` key, read once per file version.

    Args:
        path: The key's value: a TOML file; "": the built-in `sim/data/items.toml`.

    Returns:
        The catalogue.

    Raises:
        InvalidInput: One line naming `catalogue` (and the file) when it cannot be used.
    """
    file = Path(path) if path else DEFAULT_CATALOGUE
    try:
        stat = file.stat()
    except OSError as exc:
        allowed = "an item catalogue TOML file"
        raise InvalidInput("catalogue", allowed, f"{path}: {exc.strerror}") from None
    if not file.is_file():
        raise InvalidInput("catalogue", "an item catalogue TOML file", f"{path}: not a file")
    try:
        return _catalogue_at(str(file), stat.st_mtime_ns, stat.st_size)
    except InvalidInput as exc:
        field = exc.field if exc.field.startswith("catalogue") else f"catalogue: {exc.field}"
        raise InvalidInput(field, exc.allowed, exc.got, exc.where or str(file)) from None


@dataclass(frozen=True)
class CatalogueFile:
    """An item catalogue as an episode config holds it: read from its file by the loaders
    (`read`), compared by the config key it was read for and its content.

    Attributes:
        path: The config's `catalogue` key it was read for ("": the built-in one).
        digest: The catalogue's content digest (`Catalogue.digest`).
        catalogue: The catalogue itself (left out of comparisons and reprs: its digest
            stands for it).
    """

    path: str
    digest: str
    catalogue: Catalogue = field(compare=False, repr=False)

    @classmethod
    def read(cls, path: object, where: str | None = None) -> CatalogueFile:
        """The catalogue of a config's `catalogue` key, read now (`episode_catalogue`).

        Args:
            path: The key's value ("": the built-in catalogue).
            where: The config file the key came from, if any.

        Returns:
            The catalogue with its key and digest.

        Raises:
            InvalidInput: One line naming `catalogue` and the file when the key is not a
                path or its file cannot be used.
        """
        ok = isinstance(path, str) and "\0" not in path
        check(ok, "catalogue", "a path to an item catalogue TOML file", path, where)
        try:
            catalogue = episode_catalogue(path)
        except InvalidInput as exc:
            raise InvalidInput(exc.field, exc.allowed, exc.got, exc.where or where) from None
        return cls(path, catalogue.digest, catalogue)


@functools.cache
def builtin_catalogue() -> CatalogueFile:
    """The built-in catalogue (`sim/data/items.toml`: the thesis's paper, plastic and
    aluminium), read once per process: what `EpisodeConfig()` runs with.

    Returns:
        The catalogue of the key "".
    """
    return CatalogueFile.read("")


@dataclass(frozen=True)
class Values:
    """Value of an item [EUR]: per item of a material (thesis table 3.3 by default) or of one
    item type of the catalogue (which overrides its material's value in the profit), or per
    kilogram (`per_kg`, a table of EUR/kg by material or item type: an item is then worth its
    own mass, as varied, times that price). A name has one or the other, not both. An item is
    worth, in this order: its type's value per item, its type's per kg, its material's per kg,
    its material's per item. Names not set take the catalogue's `value_eur` of their
    material. The decision managers weigh a material valued per kg by its mean item: the price
    times the catalogue's mean mass of its item types (their `weight`s; `mean_masses`).

    Attributes:
        eur: (name, EUR per item) pairs as the `[values]` table gives them.
        per_kg: (name, EUR per kg) pairs of its `per_kg` table [EUR/kg].
    """

    eur: tuple[tuple[str, float], ...] = ()
    per_kg: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        pairs = tuple((k, v) for k, v in self.eur)
        for name, got in pairs:
            RANGES["values.<material>"].check(f"values.{name}", got)
        per_kg = tuple((k, v) for k, v in self.per_kg)
        for name, got in per_kg:
            RANGES["values.per_kg.<material>"].check(f"values.per_kg.{name}", got)
        both = [name for name, _ in per_kg if name in dict(pairs)]
        if both:
            allowed = f"a value per item or per kg (values.per_kg.{both[0]}), not both"
            raise InvalidInput(f"values.{both[0]}", allowed, dict(pairs)[both[0]])
        object.__setattr__(self, "eur", pairs)
        object.__setattr__(self, "per_kg", per_kg)

    @classmethod
    def from_table(cls, table: dict[str, Any]) -> Values:
        """The `[values]` table.

        Args:
            table: {material or item type name: EUR}, and `per_kg`: {name: EUR/kg}.

        Returns:
            The values as given.
        """
        per_kg = table.get("per_kg", {})
        allowed = "a table of EUR per kg by material or item type"
        check(isinstance(per_kg, dict), "values.per_kg", allowed, per_kg, None)
        eur = tuple((k, v) for k, v in table.items() if k != "per_kg")
        return cls(eur, tuple(per_kg.items()))

    def given(self) -> dict[str, float]:
        """The values per item as set.

        Returns:
            {material or item type name: EUR}.
        """
        return {k: float(v) for k, v in self.eur}

    def given_per_kg(self) -> dict[str, float]:
        """The values per kilogram as set.

        Returns:
            {material or item type name: EUR/kg}.
        """
        return {k: float(v) for k, v in self.per_kg}

    def of_materials(self, materials: Materials) -> tuple[float, ...]:
        """Each material's value per item, the catalogue's where not set.

        Args:
            materials: The catalogue's materials.

        Returns:
            EUR per material, in the materials' order (the decision managers' order).
        """
        given = self.given()
        return tuple(
            given.get(n, d) for n, d in zip(materials.names, materials.values_eur, strict=True)
        )

    def for_planning(self, catalogue: Catalogue) -> tuple[float, ...]:
        """Each material's value per item as the decision managers weigh it: a material priced
        per kg at its mean item's mass (`mean_masses`), the others as `of_materials`.

        Args:
            catalogue: The item catalogue.

        Returns:
            EUR per material, in the materials' order.
        """
        per_kg = self.given_per_kg()
        if not per_kg:
            return self.of_materials(catalogue.materials)
        masses = mean_masses(catalogue)
        return tuple(
            per_kg[n] * masses[n] if n in per_kg else v
            for n, v in zip(
                catalogue.materials.names, self.of_materials(catalogue.materials), strict=True
            )
        )

    def by_class(self, materials: Materials) -> dict[int, float]:
        """Each material's value by class id.

        Args:
            materials: The catalogue's materials.

        Returns:
            {material class id (2, 3, ...): EUR}.
        """
        return dict(zip(materials.ids, self.of_materials(materials), strict=True))

    def of_types(self, catalogue: Catalogue) -> dict[int, float]:
        """The values of the item types given a value per item of their own (their shape
        variants, a crushed can of a can type, take it too).

        Args:
            catalogue: The item catalogue the names are of.

        Returns:
            {catalogue type index: EUR}.
        """
        given = self.given()
        out = {}
        for k, t in enumerate(catalogue.types):
            base = t.variant_of or t.name
            if base in given:
                out[k] = given[base]
        return out

    def of_items(self, catalogue: Catalogue, types, masses) -> dict[int, float]:
        """The values of single items that are not their material's value per item: their
        type's own value per item, else their mass times their type's or material's price
        per kg.

        Args:
            catalogue: The item catalogue.
            types: Each item's base type index (`Flow.type_index`), by item id.
            masses: Each item's mass as varied [kg], by item id.

        Returns:
            {item id: EUR} of those items.
        """
        by_type = self.of_types(catalogue)
        per_kg = self.given_per_kg()
        out = {}
        for i, (k, mass) in enumerate(zip(types, masses, strict=True)):
            t = catalogue.types[int(k)]
            if int(k) in by_type:
                out[i] = by_type[int(k)]
            elif (t.variant_of or t.name) in per_kg:
                out[i] = per_kg[t.variant_of or t.name] * float(mass)
            elif t.material in per_kg:
                out[i] = per_kg[t.material] * float(mass)
        return out

    def check_names(self, catalogue: Catalogue, where: str | None) -> None:
        """Refuse a name that is neither a material nor a base item type of `catalogue`.

        Args:
            catalogue: The item catalogue the names must be of.
            where: The config file, named by the refusal.
        """
        names = set(catalogue.materials.names)
        names |= {t.name for t in catalogue.types if not t.variant_of}
        allowed = "a material (" + ", ".join(catalogue.materials.names) + ") or item type"
        for name, _ in self.eur:
            check(name in names, f"values.{name}", allowed, None, where)
        for name, _ in self.per_kg:
            check(name in names, f"values.per_kg.{name}", allowed, None, where)

    def table(self, materials: Materials) -> dict[str, Any]:
        """The resolved `[values]` table.

        Args:
            materials: The catalogue's materials.

        Returns:
            {name: EUR}: every material's value per item (but those priced per kg), then the
            item types' given; `per_kg` {name: EUR/kg} when any is set.
        """
        per_kg = self.given_per_kg()
        out = {
            n: v
            for n, v in zip(materials.names, self.of_materials(materials), strict=True)
            if n not in per_kg
        }
        out.update({k: v for k, v in self.given().items() if k not in out})
        if per_kg:
            out["per_kg"] = per_kg
        return out


def mean_masses(catalogue: Catalogue) -> dict[str, float]:
    """Each material's mean item mass by the catalogue's weights of its base types (nominal
    sizes) [kg].

    Args:
        catalogue: The item catalogue.

    Returns:
        {material name: kg}.
    """
    out = {}
    for name in catalogue.materials.names:
        types = [catalogue.types[k] for k in catalogue.of_material(name)]
        total = sum(t.weight for t in types)
        out[name] = sum(t.weight * t.mass for t in types) / total
    return out


MIX_KEYS = ("mix", "mix_types")
"""The `[flow]` keys giving the mix as shares (`sim.flow.mix`): by material, by item type."""


@dataclass(frozen=True)
class FlowMix:
    """The flow's class mix (`sim.flow.config.FlowConfig`): None takes the default for the
    catalogue's materials (the thesis's for paper, plastic and aluminium).

    Attributes:
        class_priors: P(class) of a stripe's first item, one per material.
        transitions: P(next class | previous class) within a stripe, one row per material.
        stripe_priors: P(stripe) of an item, 5 entries.
        mix: The share of each material among the items, every material of the catalogue
            named, shares summing to 1: the transitions (given or default) are matched to
            them and each stripe's first item is drawn from them (`sim.flow.mix`).
        mix_types: The share of each base item type of the catalogue among the items
            (summing to 1; a type not named is not drawn): the materials' shares are their
            types' sums, matched as `mix`'s, and the types are drawn within their material
            by their shares.
    """

    class_priors: tuple[float, ...] | None = None
    transitions: tuple[tuple[float, ...], ...] | None = None
    stripe_priors: tuple[float, ...] | None = None
    mix: tuple[tuple[str, float], ...] | None = None
    mix_types: tuple[tuple[str, float], ...] | None = None

    def __post_init__(self) -> None:
        for name in ("class_priors", "stripe_priors"):
            v = getattr(self, name)
            ok = v is None or (isinstance(v, list | tuple) and all(is_number(x) for x in v))
            check(ok, f"flow.{name}", "a list of probabilities", v, None)
            if v is not None:
                object.__setattr__(self, name, tuple(float(x) for x in v))
        v = self.transitions
        ok = v is None or (
            isinstance(v, list | tuple)
            and all(isinstance(r, list | tuple) and all(is_number(x) for x in r) for r in v)
        )
        check(ok, "flow.transitions", "a list of rows of probabilities", v, None)
        if v is not None:
            object.__setattr__(self, "transitions", tuple(tuple(float(x) for x in r) for r in v))
        for name in MIX_KEYS:
            self._check_shares(name)
        both = self.mix is not None and self.mix_types is not None
        check(not both, "flow.mix_types", "unset when flow.mix is given (one mix)", None, None)
        given = self.mix is not None or self.mix_types is not None
        allowed = "unset when flow.mix or flow.mix_types is given (a stripe's first item is "
        allowed += "drawn from the mix)"
        clash = given and self.class_priors is not None
        check(not clash, "flow.class_priors", allowed, self.class_priors, None)

    def _check_shares(self, name: str) -> None:
        """Refuse a mix that is not a table of shares in [0, 1] summing to 1; keep it as
        (name, share) pairs."""
        v = getattr(self, name)
        if v is None:
            return
        if isinstance(v, dict):
            v = tuple(v.items())
        ok = isinstance(v, tuple) and all(
            isinstance(p, tuple) and len(p) == 2 and isinstance(p[0], str) and is_number(p[1])
            for p in v
        )
        example = {
            "mix": "{ paper = 0.4, plastic = 0.35, aluminium = 0.25 }",
            "mix_types": "{ paper_sheet_a4 = 0.4, pet_bottle_0l5 = 0.35, can_330_lying = 0.25 }",
        }[name]
        ok = ok and bool(v)
        check(ok, f"flow.{name}", f"a table of shares by name, e.g. {example}", v, None)
        shares = dict(v)
        r = RANGES[f"flow.{name}"]
        fine = all(r.allows(x) for x in shares.values()) and abs(sum(shares.values()) - 1) <= 1e-6
        check(fine, f"flow.{name}", r.allowed, shares, None)
        object.__setattr__(self, name, tuple((k, float(x)) for k, x in v))

    def check_names(self, catalogue: Catalogue, where: str | None) -> None:
        """Refuse a `mix` that does not name every material of `catalogue` (and nothing else),
        a `mix_types` naming anything but its base item types.

        Args:
            catalogue: The episode's item catalogue.
            where: The config file, named by the refusal.
        """
        names = catalogue.materials.names
        if self.mix is not None:
            given = [k for k, _ in self.mix]
            ok = sorted(given) == sorted(names)
            allowed = "one share per material of the catalogue: " + ", ".join(names)
            check(ok, "flow.mix", allowed, given, where)
        if self.mix_types is not None:
            bases = [t.name for t in catalogue.types if not t.variant_of]
            for name, _ in self.mix_types:
                allowed = "a base item type of the catalogue (" + ", ".join(bases) + ")"
                check(name in bases, f"flow.mix_types.{name}", allowed, None, where)

    def flow_kwargs(self, catalogue: Catalogue | None = None) -> dict[str, Any]:
        """The `FlowConfig` keywords of this mix.

        Args:
            catalogue: The episode's item catalogue (needed with `mix` or `mix_types`).

        Returns:
            {keyword: value} of the fields set; with `mix` or `mix_types`, the class priors
            (the shares), the transitions matched to them (`sim.flow.mix`), the shares each
            flow is held to (`held_shares`) and, of `mix_types`, the item types' weights.
        """
        names = ("class_priors", "transitions", "stripe_priors")
        out = {n: getattr(self, n) for n in names if getattr(self, n) is not None}
        if self.mix is None and self.mix_types is None:
            return out
        materials = catalogue.materials
        if self.mix is not None:
            shares = [dict(self.mix)[n] for n in materials.names]
        else:
            shares, weights = flow_mix.shares_of_types(catalogue, dict(self.mix_types))
            out["type_weights"] = tuple(float(w) for w in weights)
        field = "flow.mix" if self.mix is not None else "flow.mix_types"
        base = self.transitions or default_transitions(materials.count)
        out["class_priors"] = tuple(float(x) for x in shares)
        out["transitions"] = flow_mix.matched_transitions(base, shares, field)
        out["held_shares"] = out["class_priors"]
        return out

    def table(self) -> dict[str, Any]:
        """The `[flow]` table as given (for a manifest: read back to an equal mix).

        Returns:
            {key: value} of the fields set, lists and tables as TOML has them.
        """
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if v is not None:
                out[f.name] = dict(v) if f.name in MIX_KEYS else _plain(v)
        return out


@dataclass(frozen=True)
class QLearning:
    """Parameters of the thesis's Q-learning decision manager (3.4.1, 4.2); the rollout planner
    takes them too. The random actions are drawn from the episode's seed.

    Attributes:
        gamma: Discount factor, in [0, 1).
        iterations: Learning iterations per decision, 1..10000.
        batch_rows: Grid rows learnt over per decision, 1..1000.
        objective: value_over_distance | value_only (d = 1) | distance_only (v = 1).
    """

    gamma: float = 0.9
    iterations: int = 50
    batch_rows: int = 20
    objective: str = "value_over_distance"

    def __post_init__(self) -> None:
        for name in ("gamma", "iterations", "batch_rows"):
            RANGES[f"qlearning.{name}"].check(f"qlearning.{name}", getattr(self, name))
        o = self.objective
        check(o in OBJECTIVES, "qlearning.objective", " | ".join(OBJECTIVES), o, None)


@dataclass(frozen=True)
class Video:
    """Settings of the episode's MP4.

    Attributes:
        fps: Frames per simulated second, 1..60.
        width: Frame width [px], 64..1920, a multiple of 8.
        height: Frame height [px], 64..1920, a multiple of 8.
    """

    fps: float = 10.0
    width: int = 640
    height: int = 360

    def __post_init__(self) -> None:
        for name in ("fps", "width", "height"):
            RANGES[f"video.{name}"].check(f"video.{name}", getattr(self, name))


CAMERA_ASPECT = (16, 9)
"""Aspect ratio of the belt camera's calibration (`models/cell/belt_camera_calibration.json`,
1280 x 720): a resolution of another shape would need its own calibration."""
CAMERA_WIDTH_RANGE = (384, 1920)
"""Frame widths accepted [px]. The pipeline finds the belt from its 4 cm corner markers: at
320 x 180 they are 8 px across, no longer fill the check patch around their place, and every
frame is refused. On the short uniform flow of `tests/test_cell_settings.py` the codes agree
with the truth's 97.1 % at 352 x 198, 97.6 % at 384 x 216, 98.8 % at 640 x 360 and 99.2 % at
960 x 540 and 1920 x 1080. 1920 x 1080 is a stereo camera's largest video mode."""
VACUUM_RANGE_PA = (1e3, 101325.0)
"""Vacuum levels accepted [Pa]: 1 kPa (a blower) to a perfect vacuum (1 atm below)."""
RANGES |= {
    "camera.width": Range(
        *CAMERA_WIDTH_RANGE,
        f"{CAMERA_WIDTH_RANGE[0]}..{CAMERA_WIDTH_RANGE[1]} px, a multiple of {CAMERA_ASPECT[0]}",
        integer=True,
        multiple=CAMERA_ASPECT[0],
    ),
    "cup.diameter_m": Range(
        *CUP_DIAMETER_RANGE_M, f"{CUP_DIAMETER_RANGE_M[0]}..{CUP_DIAMETER_RANGE_M[1]} m"
    ),
    "cup.vacuum_pa": Range(
        *VACUUM_RANGE_PA, f"{VACUUM_RANGE_PA[0]:g}..{VACUUM_RANGE_PA[1]:g} Pa (1 atm)"
    ),
    "belt.length_m": Range(
        *BELT_LENGTH_RANGE_M, f"{BELT_LENGTH_RANGE_M[0]}..{BELT_LENGTH_RANGE_M[1]} m"
    ),
    "belt.speed_mps": Range(
        *SPEED_RANGE_MPS,
        f"{SPEED_RANGE_MPS[0]}..{SPEED_RANGE_MPS[1]} m/s (the conveyor's range)",
        slack=(1e-9, _SPEED_TOLERANCE_MPS),
    ),
    "infeed.items_per_m": Range(
        MIN_FEED_RATE,
        LINE_MAX_ITEMS_PER_METRE,
        f"{MIN_FEED_RATE:g}..{LINE_MAX_ITEMS_PER_METRE:g} items per metre of belt",
    ),
    "infeed.items_per_s": Range(
        MIN_FEED_RATE,
        MAX_ITEMS_PER_S,
        f"{MIN_FEED_RATE:g}..{MAX_ITEMS_PER_S:g} items/s ({LINE_MAX_ITEMS_PER_METRE:g} per "
        "metre of belt at its top speed)",
    ),
    "infeed.kg_per_h": Range(
        MIN_FEED_RATE,
        MAX_KG_PER_H,
        f"{MIN_FEED_RATE:g}..{MAX_KG_PER_H:g} kg/h ({MAX_ITEMS_PER_S:g} items/s of "
        f"{MASS_RANGE_KG[1]:g} kg)",
    ),
    "belt.width_m": Range(
        *BELT_WIDTH_RANGE_M, f"{BELT_WIDTH_RANGE_M[0]}..{BELT_WIDTH_RANGE_M[1]} m"
    ),
}


@dataclass(frozen=True)
class Camera:
    """The belt camera's frame size: the calibration is scaled to it, the stereo depth (and
    its noise, correlated over pixels) comes at it, so coarser frames see coarser items; and
    whether a line's every robot has its own camera.

    Attributes:
        width: Frame width [px] (`CAMERA_WIDTH_RANGE`, a multiple of 16).
        height: Frame height [px]: width x 9/16.
        per_robot: A line of several robots with camera perception: each robot its own belt
            camera upstream of its reach (`sim.model.line_model`; a model setting: the line is
            compiled with them), all observed every period, their detections fused in the one
            tracker (`sim.sensing.tracking`). False: the one camera upstream of the first
            robot. No effect with one robot or truth perception.
    """

    width: int = FRAME_SIZE[0]
    height: int = FRAME_SIZE[1]
    per_robot: bool = False

    def __post_init__(self) -> None:
        aw, ah = CAMERA_ASPECT
        w, h = self.width, self.height
        RANGES["camera.width"].check("camera.width", w)
        allowed = f"width x {ah}/{aw} (the calibration's {aw}:{ah}): {w * ah // aw} px"
        check(is_integer(h) and h * aw == w * ah, "camera.height", allowed, h, None)
        v = self.per_robot
        check(isinstance(v, bool), "camera.per_robot", "true | false", v, None)

    @property
    def size(self) -> tuple[int, int]:
        """The frame size.

        Returns:
            (width, height) [px].
        """
        return (self.width, self.height)


@dataclass(frozen=True)
class Cup:
    """The vacuum cup; the holding force is lip area x vacuum (`sim.cell.suction`).

    Attributes:
        diameter_m: The lip's diameter [m] (`CUP_DIAMETER_RANGE_M`; a model setting: the cell
            is compiled with it); unset (None): 0.06 for one robot, 0.05 for a line of two or
            more (`EpisodeConfig.cup_diameter_m`; docs/line.md, "Every item").
        vacuum_pa: The vacuum it holds with, below atmosphere [Pa] (`VACUUM_RANGE_PA`).
    """

    diameter_m: float | None = None
    vacuum_pa: float = 80e3

    def __post_init__(self) -> None:
        if self.diameter_m is not None:
            RANGES["cup.diameter_m"].check("cup.diameter_m", self.diameter_m)
        RANGES["cup.vacuum_pa"].check("cup.vacuum_pa", self.vacuum_pa)


@dataclass(frozen=True)
class Belt:
    """The belt.

    Attributes:
        length_m: Its length from the infeed [m] (`BELT_LENGTH_RANGE_M`; a model setting: the
            cell is compiled with it; its discharge end moves, the camera and the robot stay).
        infeed_hold: Whether the infeed holds an item back while it would drop into one
            already there (`sim.episode.infeed`).
        speed_mps: Its speed [m/s], in the conveyor's range, instead of the top-level
            `speed_factor` (which then follows: speed / 0.185 m/s; a file giving both is
            refused). None: `speed_factor`'s.
        width_m: Its width [m] (`BELT_WIDTH_RANGE_M`; a model setting: the cell is compiled
            with it, its rails, the bins and the camera's markers keep their distance from its
            edges; the five stripes share it). Items the robots cannot reach ride past them
            and are missed (docs/world.md).
    """

    length_m: float = BELT_LENGTH_M
    infeed_hold: bool = True
    speed_mps: float | None = None
    width_m: float = BELT_WIDTH_M

    def __post_init__(self) -> None:
        RANGES["belt.length_m"].check("belt.length_m", self.length_m)
        RANGES["belt.width_m"].check("belt.width_m", self.width_m)
        v = self.infeed_hold
        check(isinstance(v, bool), "belt.infeed_hold", "true | false", v, None)
        if self.speed_mps is not None:
            RANGES["belt.speed_mps"].check("belt.speed_mps", self.speed_mps)
            object.__setattr__(self, "speed_mps", float(self.speed_mps))


@dataclass(frozen=True)
class InfeedRate:
    """The feed in a plant's units, instead of `items` (`sim.flow.feed_rate`): at most one
    key; the item count is the rate over `duration_s`, rounded to the nearest item.

    Attributes:
        items_per_m: Items per metre of belt [items/m]: items = this x belt speed x
            duration_s.
        items_per_s: Items per second [items/s]: items = this x duration_s.
        kg_per_h: Kilograms per hour [kg/h]: items = this / 3600 / the mean item mass x
            duration_s, the mean of the catalogue's masses under the flow's mix
            (`sim.flow.mix.mean_item_mass_kg`).
    """

    items_per_m: float | None = None
    items_per_s: float | None = None
    kg_per_h: float | None = None

    def __post_init__(self) -> None:
        given = [k for k in FEED_KEYS if getattr(self, k) is not None]
        allowed = "one of " + ", ".join(FEED_KEYS) + " (a rate), not several"
        check(len(given) <= 1, "infeed", allowed, given, None)
        for key in given:
            RANGES[f"infeed.{key}"].check(f"infeed.{key}", getattr(self, key))
            object.__setattr__(self, key, float(getattr(self, key)))

    @property
    def rate(self) -> tuple[str, float] | None:
        """The rate given, as (key, value in its unit); None: the feed is `items`."""
        for key in FEED_KEYS:
            if getattr(self, key) is not None:
                return key, getattr(self, key)
        return None


@dataclass(frozen=True)
class Hmm:
    """The stripe HMMs of camera perception (`sim.sensing.perception`).

    Attributes:
        coupled: Each stripe's transitions depend on its neighbour stripes' states at t-1
            (thesis 1.3; `perception.hmm.stripes`): the models are trained coupled and the
            online filter mixes each stripe's transitions by its neighbours' filtered
            posteriors of the row before. False: the five stripes' HMMs independent.
    """

    coupled: bool = False

    def __post_init__(self) -> None:
        v = self.coupled
        check(isinstance(v, bool), "hmm.coupled", "true | false", v, None)


ECONOMICS_RANGES = {
    "robot_capital_eur": (0.0, 1e9, "EUR"),
    "robot_life_years": (1.0, 50.0, "years"),
    "hours_per_year": (1.0, 8784.0, "h (366 days x 24 h)"),
    "robot_maintenance_eur_per_year": (0.0, 1e8, "EUR"),
}
"""(lowest, highest, unit in words) of the `[economics]` numbers."""
RANGES |= {
    f"economics.{name}": Range(lo, hi, f"{lo:g}..{hi:g} {unit}")
    for name, (lo, hi, unit) in ECONOMICS_RANGES.items()
}
RANGES["economics.energy_price_eur_per_kwh"] = RANGES["energy_price_eur_per_kwh"]


@dataclass(frozen=True)
class Economics:
    """What a robot costs the plant, for the profit per hour net of the robots and the payback
    of one more robot (`sim.results.economics`). The defaults are an assumption for one delta
    robot cell (robot, cup, vacuum, controller and guarding: 60-90 kEUR installed), to be set
    to the plant's own figures; they change no episode, only the money columns.

    Attributes:
        robot_capital_eur: Each robot's capital cost, installed [EUR]. The default is an
            assumption: the middle of 60-90 kEUR for one delta robot cell (robot, cup, vacuum,
            controller, guarding); set the plant's own quote.
        robot_life_years: Years over which the capital is written off, straight-line, no
            interest [years].
        hours_per_year: Hours the line runs a year (the default: two shifts of 8 h on 250
            days) [h/year].
        robot_maintenance_eur_per_year: Each robot's maintenance a year (cups, belts, service
            contract; the default about 4 % of the capital, an assumption) [EUR/year].
        energy_price_eur_per_kwh: The motors' energy price [EUR/kWh]: the top-level
            `energy_price_eur_per_kwh` set here (unset: that key's, 0 by default); give it in
            one of the two places (two different prices are refused; `--energy-price`
            overrides both). The episode records the motors' energy either way.
    """

    robot_capital_eur: float = 75000.0
    robot_life_years: float = 10.0
    hours_per_year: float = 4000.0
    robot_maintenance_eur_per_year: float = 3000.0
    energy_price_eur_per_kwh: float | None = None

    def __post_init__(self) -> None:
        for name in ECONOMICS_RANGES:
            RANGES[f"economics.{name}"].check(f"economics.{name}", getattr(self, name))
        price = self.energy_price_eur_per_kwh
        if price is not None:
            key = "economics.energy_price_eur_per_kwh"
            RANGES[key].check(key, price)

    @property
    def robot_cost_per_h_eur(self) -> float:
        """One robot's cost per running hour: capital over its life's hours plus maintenance
        over the year's hours [EUR/h]."""
        return robot_cost_per_h(
            self.robot_capital_eur,
            self.robot_life_years,
            self.hours_per_year,
            self.robot_maintenance_eur_per_year,
        )


@dataclass(frozen=True)
class EpisodeConfig:
    """One episode of the sorting cell (or line); validated on construction.

    Every attribute but `catalogue_file` and `where` is a key of the config file (module
    docstring, where each is described with its unit and range). Build one with `load` or
    `from_dict` (which read the catalogue file), `EpisodeConfig.build` (the same from keyword
    fields), `EpisodeConfig()` with fields (the built-in catalogue only: it reads no file) or
    `config.replace(...)`.

    Attributes:
        robots: The robots, upstream first (1..`MAX_ROBOTS` `RobotSpec`s). Constructing with an
            int N gives N robots at the default spacing with the default pauses;
            `config.replace(robots=N)` keeps the pauses (`sim.episode.line_robots.resized`).
        catalogue: The item catalogue's file as the config names it ("": the built-in one);
            what a manifest records.
        catalogue_file: That file's catalogue, read by the loaders (None: the built-in one,
            for a config of `catalogue = ""` only); compared by its content digest.
        where: The config file the settings came from, named by every refusal (not compared).
    """

    seed: int = 0
    items: int = 100
    speed_factor: float = 1.0
    planner: str = "qlearning"
    perception: str = "camera"
    duration_s: float = 90.0
    horizon_s: float | None = None
    observation_period_s: float = 0.5
    item_riding: str = "path"
    energy_price_eur_per_kwh: float = 0.0
    min_class_confidence: float | None = None
    classifier: str = "fused"
    depth_noise: bool = True
    world: str = "varied"
    size_jitter: float | None = None
    crushed_share: float | None = None
    crumpled_share: float | None = None
    folded_share: float | None = None
    hue_jitter_deg: float | None = None
    colour_jitter: float | None = None
    label_share: float | None = None
    min_gap_m: float | None = None
    overlap_share: float | None = None
    overlap_depth_m: float | None = None
    robots: tuple[RobotSpec, ...] = (RobotSpec(),)
    coordination: str = "coordinated"
    catalogue: str = ""
    values: Values = field(default_factory=Values)
    flow: FlowMix = field(default_factory=FlowMix)
    qlearning: QLearning = field(default_factory=QLearning)
    video: Video = field(default_factory=Video)
    camera: Camera = field(default_factory=Camera)
    cup: Cup = field(default_factory=Cup)
    belt: Belt = field(default_factory=Belt)
    hmm: Hmm = field(default_factory=Hmm)
    economics: Economics = field(default_factory=Economics)
    infeed: InfeedRate = field(default_factory=InfeedRate)
    catalogue_file: CatalogueFile | None = field(default=None, repr=False)
    where: str | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        self._check_settings()
        self._take_energy_price()
        w = self.where
        r = self.robots
        if not isinstance(r, tuple | list):
            r = (RobotSpec(),) * check_count(r, w)
        allowed = f"1..{MAX_ROBOTS} robots, or an array of 1..{MAX_ROBOTS} [[robots]] tables"
        check(1 <= len(r) <= MAX_ROBOTS, "robots", allowed, r, w)
        object.__setattr__(self, "robots", tuple(r))
        c = self.coordination
        check(c in COORDINATIONS, "coordination", " | ".join(COORDINATIONS), c, w)
        catalogue = self._catalogue()
        _check_catalogue_varied(self.world_variation, catalogue, self.catalogue)
        self.values.check_names(catalogue, w)
        check_robots(self.robots, catalogue.materials, w)
        # Every material's value written out (the catalogue's where not given), so configs
        # compare equal by what they run with, and a manifest's table reads back the same.
        resolved = Values.from_table(self.values.table(catalogue.materials))
        object.__setattr__(self, "values", resolved)
        self.flow.check_names(catalogue, w)
        try:
            _ = self.mix_kwargs  # the transitions matched to a mix, refused here if they cannot be
        except InvalidInput as exc:
            raise InvalidInput(exc.field, exc.allowed, exc.got, w) from None
        self._resolve_belt_speed()
        self._resolve_feed()
        self._check_flow()

    def _resolve_belt_speed(self) -> None:
        """`speed_factor` of a `[belt] speed_mps`: the speed over x1 (a factor given too is
        refused unless it is that one)."""
        v = self.belt.speed_mps
        if v is None:
            return
        derived = v / BELT_SPEED_X1_MPS
        f = self.speed_factor
        allowed = (
            f"unset when belt.speed_mps is given (one belt speed: {v:g} m/s is x{derived:.4g})"
        )
        check(f in (DEFAULT_SPEED_FACTOR, derived), "speed_factor", allowed, f, self.where)
        object.__setattr__(self, "speed_factor", derived)

    def _resolve_feed(self) -> None:
        """`items` of an `[infeed]` rate: the rate over `duration_s` (`sim.flow.feed_rate`),
        refused past the densest belt or outside 1..`MAX_ITEMS` items (an `items` given too is
        refused unless it is that count)."""
        rate = self.infeed.rate
        if rate is None:
            return
        key, value = rate
        w, v, most = self.where, self.belt_speed_mps, self.max_items_per_metre
        per_m = feed_rate.items_per_metre(key, value, v, self.mean_item_mass_kg)
        allowed = f"at most {most:g} items per metre of belt ({most * v:g} items/s at {v:g} m/s)"
        check(per_m <= most * (1 + 1e-9), f"infeed.{key}", allowed, value, w)
        count = feed_rate.item_count(per_m, v, float(self.duration_s), most)
        allowed = f"a feed of 1..{MAX_ITEMS} items over duration_s ({self.duration_s:g} s)"
        check(1 <= count <= MAX_ITEMS, f"infeed.{key}", allowed, value, w)
        allowed = f"unset when infeed.{key} is given (one feed: {value:g} gives {count} items)"
        check(self.items in (DEFAULT_ITEMS, count), "items", allowed, self.items, w)
        object.__setattr__(self, "items", count)

    def _check_settings(self) -> None:
        """The settings that need no catalogue: the episode's numbers and names, the world."""
        w = self.where
        for key in ("seed", "items", "speed_factor"):
            RANGES[key].check(key, getattr(self, key), w)
        check(isinstance(self.planner, str), "planner", ALLOWED_PLANNERS, self.planner, w)
        try:
            check_planner(self.planner)
        except RefusedInput as exc:
            raise InvalidInput("planner", exc.allowed, self.planner, w) from None
        p = self.perception
        check(p in PERCEPTIONS, "perception", " | ".join(PERCEPTIONS), p, w)
        for key in ("duration_s", "observation_period_s"):
            RANGES[key].check(key, getattr(self, key), w)
        if self.horizon_s is not None:  # None: the run ends once the belt is clear
            RANGES["horizon_s"].check("horizon_s", self.horizon_s, w)
        r = self.item_riding
        check(r in ITEM_RIDINGS, "item_riding", " | ".join(ITEM_RIDINGS), r, w)
        RANGES["energy_price_eur_per_kwh"].check(
            "energy_price_eur_per_kwh", self.energy_price_eur_per_kwh, w
        )
        if self.min_class_confidence is not None:  # None: the classifier's own
            RANGES["min_class_confidence"].check(
                "min_class_confidence", self.min_class_confidence, w
            )
        k = self.classifier
        check(k in CLASSIFIERS, "classifier", " | ".join(CLASSIFIERS), k, w)
        check(
            isinstance(self.depth_noise, bool), "depth_noise", "true | false", self.depth_noise, w
        )
        for name, cls in _SECTIONS.items():
            check(isinstance(getattr(self, name), cls), name, f"a [{name}] table", None, w)
        check(self.world in WORLDS, "world", " | ".join(WORLDS), self.world, w)
        for name in WORLD_NUMBERS:
            v = getattr(self, name)
            check(v is None or is_number(v), name, "a number", v, w)
        try:
            _ = self.world_variation
        except InvalidInput as exc:
            raise InvalidInput(exc.field, exc.allowed, exc.got, w) from None

    def _take_energy_price(self) -> None:
        """The `[economics]` energy price as the episode's (`energy_price_eur_per_kwh`);
        refused when the top-level key gives another."""
        price = self.economics.energy_price_eur_per_kwh
        if price is None:
            return
        top = self.energy_price_eur_per_kwh
        allowed = f"the top-level energy_price_eur_per_kwh's {top:g}, or that key unset"
        key = "economics.energy_price_eur_per_kwh"
        check(top in (0.0, price), key, allowed, price, self.where)
        object.__setattr__(self, "energy_price_eur_per_kwh", float(price))

    def _catalogue(self) -> Catalogue:
        """The catalogue the loaders read for `catalogue` (the built-in one for ""); refused
        when `catalogue_file` was read for another key (no file is read here)."""
        w = self.where
        ok = isinstance(self.catalogue, str) and "\0" not in self.catalogue
        check(ok, "catalogue", "a path to an item catalogue TOML file", self.catalogue, w)
        if self.catalogue_file is None and self.catalogue == "":
            object.__setattr__(self, "catalogue_file", builtin_catalogue())
        loaded = self.catalogue_file
        ok = isinstance(loaded, CatalogueFile) and loaded.path == self.catalogue
        allowed = "a catalogue file read by load, from_dict, EpisodeConfig.build or replace"
        check(ok, "catalogue", allowed, self.catalogue, w)
        return loaded.catalogue

    @classmethod
    def build(cls, **fields: Any) -> EpisodeConfig:
        """A config of keyword `fields` whose `catalogue` file is read here (what
        `EpisodeConfig(...)` does not do: it knows the built-in catalogue only).

        Args:
            **fields: Any fields of the config (`robots` may be a count).

        Returns:
            The validated config.
        """
        if "catalogue_file" not in fields:
            path, where = fields.get("catalogue", ""), fields.get("where")
            fields["catalogue_file"] = CatalogueFile.read(path, where)
        return cls(**fields)

    @property
    def item_catalogue(self) -> Catalogue:
        """The item catalogue (of `catalogue`; the built-in one when "")."""
        return self.catalogue_file.catalogue

    @property
    def robot_count(self) -> int:
        """How many robots the episode runs (1: the single cell's, or a line's one)."""
        return len(self.robots)

    @property
    def materials(self) -> Materials:
        """The catalogue's materials: the classes, one bin each."""
        return self.item_catalogue.materials

    def flow_config(self) -> FlowConfig:
        """The episode's flow settings.

        Returns:
            The `FlowConfig` of this episode's items, belt, seed and class mix.
        """
        return FlowConfig(
            n_items=self.items,
            duration_s=self.duration_s,
            speed_factor=self.speed_factor,
            seed=self.seed,
            observation_period_s=self.observation_period_s,
            world=self.world_variation,
            n_materials=self.materials.count,
            max_items_per_metre=self.max_items_per_metre,
            belt_width_m=self.belt.width_m,
            **self.mix_kwargs,
        )

    @functools.cached_property
    def mix_kwargs(self) -> dict[str, Any]:
        """The `FlowConfig` keywords of the flow's class mix (`FlowMix.flow_kwargs`): the
        `[flow]` table's as given, or with `mix` or `mix_types` the shares and the transitions
        matched to them (`sim.flow.mix`). What the flow, its stripe HMMs and the item
        classifier's table are made with."""
        return self.flow.flow_kwargs(self.item_catalogue)

    @property
    def material_shares(self) -> tuple[float, ...]:
        """Each material's long-run share of the items, in the catalogue's order: the mix's, or
        the stationary distribution of the flow's transitions (`sim.flow.mix`)."""
        kwargs = self.mix_kwargs
        if self.flow.mix is not None or self.flow.mix_types is not None:
            return tuple(kwargs["class_priors"])
        table = kwargs.get("transitions") or default_transitions(self.materials.count)
        return tuple(float(x) for x in flow_mix.stationary_shares(table))

    @property
    def mean_item_mass_kg(self) -> float:
        """The mean mass of an item of the flow [kg]: the catalogue's masses under the mix
        (`sim.flow.mix.mean_item_mass_kg`; what `[infeed] kg_per_h` counts items with)."""
        weights = self.mix_kwargs.get("type_weights")
        return flow_mix.mean_item_mass_kg(self.item_catalogue, self.material_shares, weights)

    @property
    def max_items_per_metre(self) -> float:
        """The densest belt an episode takes (`LINE_MAX_ITEMS_PER_METRE`: a line's pool)."""
        return LINE_MAX_ITEMS_PER_METRE

    @property
    def robot_positions_m(self) -> tuple[float, ...]:
        """x of each robot's base along the belt, upstream first [m] (the `[[robots]]` table's
        `x_m`); () when not given: the line's default spacing (`sim.model.line_model`)."""
        return tuple(s.x_m for s in self.robots if s.x_m is not None)

    @functools.cached_property
    def robot_class_ids(self) -> tuple[frozenset[int] | None, ...]:
        """Per robot, upstream first, the material class ids (2, 3, ...) it sorts; None: every
        material (`planner.decision.robot_materials`)."""
        return tuple(class_ids_of(s.materials, self.materials) for s in self.robots)

    @property
    def line_cell(self) -> bool:
        """Whether the episode runs on a line's model (`sim.cell.line`): several robots, one
        robot placed elsewhere than x = 0, or one robot on a belt denser than the single
        cell's pool carries (`MAX_ITEMS_PER_METRE`)."""
        if self.robot_count > 1 or self.robot_positions_m[:1] not in ((), (0.0,)):
            return True
        density = self.items / (self.duration_s * self.belt_speed_mps)
        return density > MAX_ITEMS_PER_METRE * (1 + 1e-9)

    @property
    def applied_min_class_confidence(self) -> float:
        """The confidence rule's threshold the episode applies, in [0, 1]: `min_class_confidence`
        when set, else the classifier's own (`sim.sensing.confidence.default_min_confidence`:
        0.9 for the camera's `fused` and `features`, 0 for `hmm` and truth)."""
        if self.min_class_confidence is not None:
            return float(self.min_class_confidence)
        return default_min_confidence(self.perception, self.classifier)

    @property
    def world_variation(self) -> WorldVariation:
        """How the items vary: the `world` preset with the numbers set here."""
        preset = WorldVariation() if self.world == "varied" else WorldVariation.uniform()
        changes = {n: getattr(self, n) for n in WORLD_NUMBERS if getattr(self, n) is not None}
        return dataclasses.replace(preset, **changes) if changes else preset

    def _check_flow(self) -> None:
        """The flow's own limits (its density: items per metre of belt), checked now rather
        than when the episode starts."""
        mix = tuple(sorted(self.mix_kwargs.items()))
        try:
            _flow_check(
                self.items,
                self.duration_s,
                self.speed_factor,
                self.observation_period_s,
                self.materials.count,
                mix,
                self.max_items_per_metre,
            )
        except InvalidInput as exc:
            key = {"n_items": "items"}.get(exc.field, exc.field)
            if key in ("class_priors", "transitions", "stripe_priors"):
                key = f"flow.{key}"
            if key == "items" and self.infeed.rate is not None:
                key = f"infeed.{self.infeed.rate[0]}"
            raise InvalidInput(key, exc.allowed, exc.got, self.where) from None

    @property
    def cell_settings(self) -> CellSettings:
        """What the cell's model is compiled with (cup diameter, belt length and width):
        episodes of different settings run on different compiled cells
        (`sim.episode.runner.shared_cell`)."""
        return CellSettings(self.cup_diameter_m, self.belt.length_m, self.belt.width_m)

    @property
    def cup_diameter_m(self) -> float:
        """The cup's diameter the episode runs with [m]: `[cup] diameter_m` when set, else the
        robots' default (`sim.model.scene_edits.default_cup_diameter_m`: 0.06 for one robot,
        0.05 for a line)."""
        if self.cup.diameter_m is not None:
            return float(self.cup.diameter_m)
        return default_cup_diameter_m(self.robot_count)

    @property
    def belt_speed_mps(self) -> float:
        """Belt speed of this episode [m/s]: `[belt] speed_mps` as given, else of
        `speed_factor`."""
        if self.belt.speed_mps is not None:
            return self.belt.speed_mps
        return belt_speed_mps(self.speed_factor)

    def replace(self, **changes: Any) -> EpisodeConfig:
        """A copy with `changes` applied (validated again).

        Args:
            **changes: Fields to change. `robots` may be a count N: N robots at the default
                spacing, each keeping its pauses (`sim.episode.line_robots.resized`); a new
                `catalogue` is read here (unless `catalogue_file` comes with it).

        Returns:
            The new config.
        """
        n = changes.get("robots")
        if is_integer(n) and 1 <= n <= MAX_ROBOTS:
            changes["robots"] = resized(self.robots, n)
        changes = self._one_spelling(changes)
        if "catalogue" in changes and "catalogue_file" not in changes:
            where = changes.get("where", self.where)
            changes["catalogue_file"] = CatalogueFile.read(changes["catalogue"], where)
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of every setting in the TOML layout (one `robots` array of tables), for
        manifests, reports and sweep keys; `from_dict` reads it back to an equal config. The
        belt's speed and the feed in the unit they were given: `speed_factor` left out beside
        `[belt] speed_mps`, `items` beside an `[infeed]` rate (so an option changing the
        duration or the speed works them out again, `load`).

        Returns:
            {key: value}, tables as dicts, arrays as lists.
        """
        out = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name not in ("catalogue_file", "where"):
                out[f.name] = dataclasses.asdict(value) if _is_table(value) else value
        out["robots"] = [spec.table() for spec in self.robots]
        out["values"] = self.values.table(self.materials)
        out["flow"] = self.flow.table()
        if self.belt.speed_mps is not None:
            del out["speed_factor"]
        if self.infeed.rate is not None:
            del out["items"]
        return out

    def _one_spelling(self, changes: dict[str, Any]) -> dict[str, Any]:
        """`changes` for `replace` with the other spelling of what they set cleared, so the
        last one given wins: a `speed_factor` clears `[belt] speed_mps`, an `items` the
        `[infeed]` rate; and a value that follows from the plant units (`speed_factor` of
        `speed_mps`, `items` of a rate) is worked out again from the new settings."""
        out = dict(changes)
        belt = out.get("belt", self.belt)
        if "speed_factor" in out and "belt" not in out and belt.speed_mps is not None:
            out["belt"] = belt = dataclasses.replace(belt, speed_mps=None)
        if belt.speed_mps is not None and "speed_factor" not in out:
            out["speed_factor"] = DEFAULT_SPEED_FACTOR  # follows belt.speed_mps again
        infeed = out.get("infeed", self.infeed)
        if "items" in out and "infeed" not in out and infeed.rate is not None:
            out["infeed"] = infeed = InfeedRate()
        if infeed.rate is not None and "items" not in out:
            out["items"] = DEFAULT_ITEMS  # follows the rate again
        return out


_VARIED_OK: set[tuple[WorldVariation, str]] = set()
"""(world, catalogue digest) pairs `_check_catalogue_varied` passed (a sweep repeats them)."""


def _check_catalogue_varied(world: WorldVariation, catalogue: Catalogue, path: str) -> None:
    """Refuse, when the config loads, a catalogue whose items the world's variation takes out of
    the catalogue's limits (`sim.flow.world.check_varied`) or out of the belt's outer stripes
    (the flow generator's rule: the item's narrowest lateral extent and the edge margin within a
    stripe), naming the key, the item and the catalogue's file.

    Args:
        world: The episode's world variation.
        catalogue: The episode's catalogue.
        path: The config's `catalogue` key ("": the built-in one).
    """
    if (world, catalogue.digest) in _VARIED_OK:
        return
    file = path or str(DEFAULT_CATALOGUE)
    try:
        check_varied(world, catalogue)
    except InvalidInput as exc:
        where = f"{file}, {exc.where}"
        raise InvalidInput(f"catalogue: {exc.field}", exc.allowed, exc.got, where) from None
    j = world.size_jitter
    for t in catalogue.types:
        big = t.scaled((1.0 + j,) * 3)
        yaw = 0.0 if big.half_width <= big.half_length else 1.5708  # the generator's last try
        if float(big.half_extents(yaw)[1]) + EDGE_MARGIN_M >= STRIPE_WIDTH:
            allowed = (
                f"an item {2 * (STRIPE_WIDTH - EDGE_MARGIN_M):g} m wide at most, so it fits the "
                f"belt's outer stripe (narrowest side, once varied by size_jitter {j:g})"
            )
            raise InvalidInput("catalogue: size", allowed, t.size, f"{file}, item {t.name!r}")
    _VARIED_OK.add((world, catalogue.digest))


def _is_table(value: Any) -> bool:
    """Whether `value` is a section's dataclass (written as a TOML table)."""
    return dataclasses.is_dataclass(value) and not isinstance(value, type)


def _plain(value: Any) -> Any:
    """Tuples as lists (TOML's and JSON's arrays), nested."""
    return [_plain(v) for v in value] if isinstance(value, tuple | list) else value


@functools.lru_cache(maxsize=4096)
def _flow_check(
    items: int,
    duration_s: float,
    speed_factor: float,
    period_s: float,
    n_materials: int = 3,
    mix: tuple = (),
    max_items_per_metre: float = MAX_ITEMS_PER_METRE,
) -> None:
    """`FlowConfig`'s checks of these settings (cached: a sweep repeats them for every seed)."""
    FlowConfig(
        n_items=items,
        duration_s=duration_s,
        speed_factor=speed_factor,
        observation_period_s=period_s,
        n_materials=n_materials,
        max_items_per_metre=max_items_per_metre,
        **dict(mix),
    )


_SECTIONS = {
    "values": Values,
    "flow": FlowMix,
    "qlearning": QLearning,
    "video": Video,
    "camera": Camera,
    "cup": Cup,
    "belt": Belt,
    "hmm": Hmm,
    "economics": Economics,
    "infeed": InfeedRate,
}
_SCALARS = {f.name for f in dataclasses.fields(EpisodeConfig)} - set(_SECTIONS)
_SCALARS -= {"where", "catalogue_file"}  # not keys: what the file names, read
_KEYS = _SCALARS | set(_SECTIONS) | {"robot"}
"""Every top-level key of a config file (`robot`: the old section of every robot's pauses)."""


def from_dict(data: dict[str, Any], where: str | None = None) -> EpisodeConfig:
    """An `EpisodeConfig` from a TOML-shaped dict (a config file's, a manifest's `config`, a
    sweep's grid point), its catalogue file read here.

    Args:
        data: The settings in the TOML layout (module docstring); `robots` a count or an array
            of tables, `[robot]` every robot's defaults.
        where: The file they came from, named by every refusal.

    Returns:
        The validated config.

    Raises:
        InvalidInput: One line naming the key (an unknown one too) and `where`.
    """
    try:
        return _from_dict(data, where)
    except InvalidInput as exc:
        if exc.where is None and where is not None:
            raise InvalidInput(exc.field, exc.allowed, exc.got, where) from None
        raise


def _from_dict(data: dict[str, Any], where: str | None) -> EpisodeConfig:
    kwargs: dict[str, Any] = {}
    section = None  # the old [robot] section: every robot's defaults
    for key, value in data.items():
        if key == "robot":
            section = robot_section(value, where)
        elif key in _SECTIONS:
            cls = _SECTIONS[key]
            check(isinstance(value, dict), key, "a table [" + key + "]", value, where)
            if cls is Values:
                kwargs[key] = Values.from_table(value)
                continue
            names = {f.name for f in dataclasses.fields(cls)}
            for sub in value:
                check(
                    sub in names, f"{key}.{sub}", "one of " + ", ".join(sorted(names)), None, where
                )
            kwargs[key] = cls(**value)
        else:
            check(key in _SCALARS, key, "one of " + ", ".join(sorted(_KEYS)), None, where)
            kwargs[key] = value
    if "robots" in kwargs or section is not None:
        kwargs["robots"] = robot_specs(kwargs.get("robots", 1), section, where)
    kwargs["catalogue_file"] = CatalogueFile.read(kwargs.get("catalogue", ""), where)
    config = EpisodeConfig(where=where, **kwargs)
    _check_one_spelling(data, config, where)
    return config


def _check_one_spelling(data: dict[str, Any], config: EpisodeConfig, where: str | None) -> None:
    """Refuse a file that gives the belt's speed or the feed twice, in both units (the config
    itself refuses any other value than the one that follows; here also the default's value
    written out, `speed_factor = 1.0` beside `[belt] speed_mps = 0.2`, and the one that
    follows)."""
    v = config.belt.speed_mps
    if "speed_factor" in data and v is not None:
        allowed = "unset when belt.speed_mps is given (one belt speed: "
        allowed += f"{v:g} m/s is x{config.speed_factor:.4g})"
        raise InvalidInput("speed_factor", allowed, data["speed_factor"], where)
    rate = config.infeed.rate
    if "items" in data and rate is not None:
        allowed = f"unset when infeed.{rate[0]} is given (one feed: {rate[1]:g} gives "
        allowed += f"{config.items} items)"
        raise InvalidInput("items", allowed, data["items"], where)


def read_config_file(path: Path) -> dict[str, Any]:
    """The settings of a config file: a TOML file, or a run folder's `manifest.json` (its
    resolved `config`), so that `sortsim run --config runs/x/manifest.json` repeats that run.

    Args:
        path: The TOML file or manifest.json.

    Returns:
        The settings in the TOML layout (for `from_dict`).

    Raises:
        InvalidInput: One line naming the file when it cannot be read or is not a run's
            manifest, or `catalogue` when the manifest's catalogue's content has changed
            since the run (`catalogue_digest`).
    """
    path = Path(path)
    if path.suffix.lower() != ".json":
        return read_toml(path)
    import json

    try:
        manifest = json.loads(path.read_bytes().decode("utf-8"))
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise InvalidInput(
            "config", "a readable TOML file or manifest.json", reason, str(path)
        ) from None
    except (UnicodeDecodeError, ValueError) as exc:
        reason = " ".join(str(exc).split())[:120]
        raise InvalidInput("config", "a run's manifest.json (JSON)", reason, str(path)) from None
    ok = isinstance(manifest, dict) and manifest.get("kind") == "run"
    if not ok or not isinstance(manifest.get("config"), dict):
        got = manifest.get("kind") if isinstance(manifest, dict) else type(manifest).__name__
        allowed = "a run's manifest.json (kind run, with its config); a sweep is repeated "
        allowed += "from its TOML"
        raise InvalidInput("config", allowed, got, str(path))
    data = manifest["config"]
    digest = manifest.get("catalogue_digest")
    if digest is not None:
        now = episode_catalogue(str(data.get("catalogue", ""))).digest
        if now != digest:
            allowed = f"the catalogue the run had (content digest {digest})"
            raise InvalidInput("catalogue", allowed, f"changed since (now {now})", str(path))
    return data


def _without_economics_price(data: dict[str, Any]) -> dict[str, Any]:
    """`data` without its `[economics]` energy price (the other keys as they are)."""
    economics = data.get("economics")
    if not isinstance(economics, dict) or "energy_price_eur_per_kwh" not in economics:
        return data
    rest = {k: v for k, v in economics.items() if k != "energy_price_eur_per_kwh"}
    return {**data, "economics": rest}


def read_toml(path: Path) -> dict[str, Any]:
    """The parsed TOML of a file.

    Args:
        path: The TOML file.

    Returns:
        Its tables as dicts.

    Raises:
        InvalidInput: One line naming the file when it is missing, unreadable, not UTF-8 or
            not valid TOML.
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise InvalidInput("config", "a readable TOML file", reason, str(path)) from None
    except UnicodeDecodeError as exc:
        got = f"not UTF-8 at byte {exc.start}"
        raise InvalidInput("config", "a UTF-8 TOML file", got, str(path)) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        reason = " ".join(str(exc).split())
        raise InvalidInput("config", f"valid TOML ({reason})", None, str(path)) from None


SECTION_OPTIONS = {
    "belt_speed_mps": ("belt", "speed_mps"),
    "items_per_m": ("infeed", "items_per_m"),
}
"""`load`'s keywords that set a section's key (the plant units of `sortsim run`'s options)."""
SPELLINGS = (
    ("speed_factor", "belt.speed_mps"),
    ("items", *(f"infeed.{k}" for k in FEED_KEYS)),
)
"""Keys that say the same thing in other units: an option setting one of a group takes the
file's others away (the belt's speed; the feed)."""


def _with_options(data: dict[str, Any], changes: dict[str, Any]) -> dict[str, Any]:
    """The settings of a file with the options applied: each option's key set (a section's
    inside its table), the file's keys of the same group of `SPELLINGS` taken away.

    Args:
        data: The file's settings (not changed).
        changes: {`load` keyword: value}.

    Returns:
        A new dict of settings.
    """
    out = {k: dict(v) if isinstance(v, dict) else v for k, v in data.items()}
    for name, value in changes.items():
        key = ".".join(SECTION_OPTIONS.get(name, (name,)))
        for group in SPELLINGS:
            for other in group if key in group else ():
                section, _, sub = other.rpartition(".")
                table = out.get(section) if section else out
                if isinstance(table, dict):
                    table.pop(sub, None)
        section, _, sub = key.rpartition(".")
        if not section:
            out[key] = value
        elif isinstance(out.setdefault(section, {}), dict):  # else the file's error, refused
            out[section][sub] = value
    return out


def load(path: Path | None = None, **overrides: Any) -> EpisodeConfig:
    """The episode config of a config file (or the defaults) with the options given applied.

    Args:
        path: A TOML file or a run's manifest.json (`read_config_file`); None: the defaults.
        **overrides: Top-level keys to set (the command line's options); None leaves a key
            as the file has it. `robots = N` gives N robots at the default spacing keeping
            the file's pauses (`EpisodeConfig.replace`); the others take the file's keys'
            place before anything is validated, so what depends on several keys (the
            materials' values on the catalogue, the catalogue's items on the world's variation)
            is checked with the options applied; `catalogue` is read here.

    Returns:
        The validated config (`where` None once options changed it).

    Raises:
        InvalidInput: One line naming the key and the file.
    """
    data = read_config_file(path) if path is not None else {}
    where = str(path) if path is not None else None
    changes = {k: v for k, v in overrides.items() if v is not None}
    unknown = set(changes) - _SCALARS - set(SECTION_OPTIONS)
    options = ", ".join(sorted(_SCALARS | set(SECTION_OPTIONS)))
    check(not unknown, "override", options, sorted(unknown), None)
    if not changes:
        return from_dict(data, where)
    robots = changes.pop("robots", None)  # a count keeps the file's robots' pauses: replace
    if "energy_price_eur_per_kwh" in changes:  # the option's price wins over [economics]'
        data = _without_economics_price(data)
    keys = {".".join(SECTION_OPTIONS.get(k, (k,))) for k in changes}
    try:
        config = from_dict(_with_options(data, changes), where)
    except InvalidInput as exc:
        if exc.field in keys:  # the option's value: not the file's
            raise InvalidInput(exc.field, exc.allowed, exc.got, None) from None
        raise
    if robots is not None:
        config = config.replace(robots=robots)
    return config.replace(where=None)
