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
    speed_factor = 1.0          # belt speed = 0.185 m/s x factor, inside 0.135..0.277 m/s
    planner = "qlearning"       # qlearning | rollout | lookahead | proximity | fifo | greedy
                                # | oracle | module:Class
    perception = "camera"       # camera | truth
    duration_s = 90.0           # items arrive over this time [s]
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
    [flow]                      # the class mix of the flow (default: the thesis's for its
    class_priors = [0.29, 0.36, 0.35]   # three materials, equal shares otherwise); one entry
    transitions = [[0.46, 0.30, 0.24],  # per material in the catalogue's order
                   [0.22, 0.50, 0.28],
                   [0.20, 0.28, 0.52]]
    stripe_priors = [0.16, 0.22, 0.24, 0.22, 0.16]
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
    length_m = 4.5              # 4..20 m from the infeed; the discharge end moves (recompiles)
    infeed_hold = true          # an item that would drop into one already on the belt is held
                                # back (sim/episode/infeed.py); false: every result to the bit
                                # as before it
    [hmm]                       # camera perception's stripe HMMs
    coupled = false             # true: each stripe's transitions use its neighbour stripes'
                                # states at t-1 (thesis 1.3); false: five independent HMMs

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
from sim.flow.catalogue import DEFAULT_CATALOGUE, Catalogue, load_catalogue
from sim.flow.config import (
    LINE_MAX_ITEMS_PER_METRE,
    MAX_ITEMS_PER_METRE,
    STRIPE_WIDTH,
    FlowConfig,
)
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
            "rows": a list of such lists.
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
    "flow.class_priors": Range(0.0, 1.0, _PROBABILITIES, entries="list", checked_by="sim.flow"),
    "flow.transitions": Range(0.0, 1.0, _PROBABILITIES, entries="rows", checked_by="sim.flow"),
    "flow.stripe_priors": Range(0.0, 1.0, _PROBABILITIES, entries="list", checked_by="sim.flow"),
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
    """Value of an item [EUR]: per material (thesis table 3.3 by default), or per item type of
    the catalogue (which overrides its material's value in the profit). Names not set take
    the catalogue's `value_eur` of their material.

    Attributes:
        eur: (name, EUR) pairs as the `[values]` table gives them.
    """

    eur: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        pairs = tuple((k, v) for k, v in self.eur)
        for name, got in pairs:
            RANGES["values.<material>"].check(f"values.{name}", got)
        object.__setattr__(self, "eur", pairs)

    @classmethod
    def from_table(cls, table: dict[str, Any]) -> Values:
        """The `[values]` table.

        Args:
            table: {material or item type name: EUR}.

        Returns:
            The values as given.
        """
        return cls(tuple(table.items()))

    def given(self) -> dict[str, float]:
        """The values as set.

        Returns:
            {material or item type name: EUR}.
        """
        return {k: float(v) for k, v in self.eur}

    def of_materials(self, materials: Materials) -> tuple[float, ...]:
        """Each material's value, the catalogue's where not set.

        Args:
            materials: The catalogue's materials.

        Returns:
            EUR per material, in the materials' order (the decision managers' order).
        """
        given = self.given()
        return tuple(
            given.get(n, d) for n, d in zip(materials.names, materials.values_eur, strict=True)
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
        """The values of the item types given a value of their own (their shape variants, a
        crushed can of a can type, take it too).

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

    def check_names(self, catalogue: Catalogue, where: str | None) -> None:
        """Refuse a name that is neither a material nor a base item type of `catalogue`.

        Args:
            catalogue: The item catalogue the names must be of.
            where: The config file, named by the refusal.
        """
        names = set(catalogue.materials.names)
        names |= {t.name for t in catalogue.types if not t.variant_of}
        for name, _ in self.eur:
            allowed = "a material (" + ", ".join(catalogue.materials.names) + ") or item type"
            check(name in names, f"values.{name}", allowed, None, where)

    def table(self, materials: Materials) -> dict[str, float]:
        """The resolved `[values]` table.

        Args:
            materials: The catalogue's materials.

        Returns:
            {name: EUR}: every material's value, then the item types' given.
        """
        out = dict(zip(materials.names, self.of_materials(materials), strict=True))
        out.update({k: v for k, v in self.given().items() if k not in out})
        return out


@dataclass(frozen=True)
class FlowMix:
    """The flow's class mix (`sim.flow.config.FlowConfig`): None takes the default for the
    catalogue's materials (the thesis's for paper, plastic and aluminium).

    Attributes:
        class_priors: P(class) of a stripe's first item, one per material.
        transitions: P(next class | previous class) within a stripe, one row per material.
        stripe_priors: P(stripe) of an item, 5 entries.
    """

    class_priors: tuple[float, ...] | None = None
    transitions: tuple[tuple[float, ...], ...] | None = None
    stripe_priors: tuple[float, ...] | None = None

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

    def flow_kwargs(self) -> dict[str, Any]:
        """The `FlowConfig` keywords set here.

        Returns:
            {keyword: value} of the fields not None.
        """
        names = ("class_priors", "transitions", "stripe_priors")
        return {n: getattr(self, n) for n in names if getattr(self, n) is not None}


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
    """

    length_m: float = BELT_LENGTH_M
    infeed_hold: bool = True

    def __post_init__(self) -> None:
        RANGES["belt.length_m"].check("belt.length_m", self.length_m)
        v = self.infeed_hold
        check(isinstance(v, bool), "belt.infeed_hold", "true | false", v, None)


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
    catalogue_file: CatalogueFile | None = field(default=None, repr=False)
    where: str | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        self._check_settings()
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
        self._check_flow()

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
            **self.flow.flow_kwargs(),
        )

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
        mix = tuple(sorted(self.flow.flow_kwargs().items()))
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
            raise InvalidInput(key, exc.allowed, exc.got, self.where) from None

    @property
    def cell_settings(self) -> CellSettings:
        """What the cell's model is compiled with (cup diameter, belt length): episodes of
        different settings run on different compiled cells (`sim.episode.runner.shared_cell`)."""
        return CellSettings(self.cup_diameter_m, self.belt.length_m)

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
        """Belt speed of this episode [m/s]."""
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
        if "catalogue" in changes and "catalogue_file" not in changes:
            where = changes.get("where", self.where)
            changes["catalogue_file"] = CatalogueFile.read(changes["catalogue"], where)
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of every setting in the TOML layout (one `robots` array of tables), for
        manifests, reports and sweep keys; `from_dict` reads it back to an equal config.

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
        out["flow"] = {k: _plain(v) for k, v in self.flow.flow_kwargs().items()}
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
    return EpisodeConfig(where=where, **kwargs)


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
    unknown = set(changes) - _SCALARS
    check(not unknown, "override", ", ".join(sorted(_SCALARS)), sorted(unknown), None)
    if not changes:
        return from_dict(data, where)
    robots = changes.pop("robots", None)  # a count keeps the file's robots' pauses: replace
    try:
        config = from_dict({**data, **changes}, where)
    except InvalidInput as exc:
        if exc.field in changes:  # the option's value: not the file's
            raise InvalidInput(exc.field, exc.allowed, exc.got, None) from None
        raise
    if robots is not None:
        config = config.replace(robots=robots)
    return config.replace(where=None)
