"""Configuration of one episode: a frozen, eagerly validated dataclass read from TOML.

Every key a TOML file may hold is a field below; unknown keys, wrong types, values out of
range and malformed TOML are refused with one line naming the key and the file
(`InvalidInput`, exit code 2) before anything runs. Command-line options override the file.

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
    min_class_confidence = 0.0  # 0..1: an item whose most probable class is less probable is
                                # left on the belt (sim/sensing/confidence.py); 0: none is
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
    overlap_share = 0.1         # items allowed to lie partly over a flat neighbour
    overlap_depth_m = 0.02      # how far over it [m]
    robots = 1                  # IRB 360s in series over the belt, 1..4 (a sorting line),
                                # or a [[robots]] table per robot (below, after the tables)
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
    [robot]                     # extra dwell after each pick / place (thesis: ~0.5 s each)
    pick_pause_s = 0.0
    place_pause_s = 0.0
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
    [cup]                       # the vacuum cup
    diameter_m = 0.06           # lip diameter 0.02..0.12 m (recompiles the cell's model)
    vacuum_pa = 80000.0         # vacuum below atmosphere, 1000..101325 Pa; holds area x vacuum
    [belt]
    length_m = 4.5              # 4..20 m from the infeed; the discharge end moves (recompiles)
    infeed_hold = true          # an item that would drop into one already on the belt is held
                                # back (sim/episode/infeed.py); false: every result to the bit
                                # as before it

A line's robots one by one, instead of `robots = N` (sim/episode/line_robots.py, docs/line.md;
`--robots N` replaces the table by N robots at the default spacing)::

    [[robots]]                  # the first robot, upstream
    x_m = 0.0                   # its base along the belt [m]; for every robot or none (then
                                # 0, 1.8, 3.6, ...): first >= 0, >= 1.8 m apart, last <= 15.5
    materials = ["aluminium"]   # what it picks (items by their most probable material);
                                # omitted: every material. Each material by some robot
    [[robots]]
    x_m = 2.2
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
from sim.episode.line_robots import LineRobotSpec, check_robots_table, robots_table
from sim.errors import InvalidInput, RefusedInput
from sim.flow.catalogue import DEFAULT_CATALOGUE, Catalogue, load_catalogue
from sim.flow.config import LINE_MAX_ITEMS_PER_METRE, MAX_ITEMS_PER_METRE, FlowConfig
from sim.flow.world import WorldVariation
from sim.model.scene_edits import (
    BELT_LENGTH_M,
    BELT_LENGTH_RANGE_M,
    CUP_DIAMETER_M,
    CUP_DIAMETER_RANGE_M,
    CellSettings,
)

BELT_SPEED_X1_MPS = SPEED_X1_MPS
BELT_SPEED_RANGE_MPS = SPEED_RANGE_MPS
# x1.5 is the belt's top speed: 0.2775 m/s rounds to the conveyor's 0.277 m/s.
_SPEED_TOLERANCE_MPS = SPEED_TOLERANCE_MPS + 1e-12  # the belt's own check, to the bit
PERCEPTIONS = ("camera", "truth")
CLASSIFIERS = ("fused", "features", "hmm")
ITEM_RIDINGS = ("path", "settled", "contact")
OBJECTIVES = ("value_over_distance", "value_only", "distance_only")
WORLDS = ("varied", "uniform")
MAX_ROBOTS = 4
"""Most robots of a line."""
WORLD_NUMBERS = tuple(f.name for f in dataclasses.fields(WorldVariation))
"""Keys overriding one number of the `world` preset (`WorldVariation`'s fields)."""
MAX_ITEMS = 20000
MAX_ENERGY_PRICE = 1e6
"""Highest energy price accepted [EUR/kWh] (far above any tariff: a stress test's price)."""


def _check(ok: bool, key: str, allowed: str, got: object, where: str | None) -> None:
    if not ok:
        raise InvalidInput(key, allowed, got, where)


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _integer(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def belt_speed_mps(speed_factor: float) -> float:
    """Belt speed [m/s] of a speed factor (x1 = 0.185 m/s)."""
    return BELT_SPEED_X1_MPS * float(speed_factor)


@functools.lru_cache(maxsize=16)
def _catalogue_at(path: str, mtime_ns: int, size: int) -> Catalogue:
    return load_catalogue(path)


def episode_catalogue(path: str) -> Catalogue:
    """The item catalogue of a config's `catalogue` key ("": the default), read once per
    file version; refused in one line (`InvalidInput`) when it cannot be used."""
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
            ok = _number(got) and 0.0 <= got <= 1e6
            _check(ok, f"values.{name}", "0..1e6 EUR", got, None)
        object.__setattr__(self, "eur", pairs)

    @classmethod
    def from_table(cls, table: dict[str, Any]) -> Values:
        """The `[values]` table: {material or item type name: EUR}."""
        return cls(tuple(table.items()))

    def given(self) -> dict[str, float]:
        """{name: EUR} as set."""
        return {k: float(v) for k, v in self.eur}

    def of_materials(self, materials: Materials) -> tuple[float, ...]:
        """EUR per material, in the materials' order (the decision managers' order)."""
        given = self.given()
        return tuple(
            given.get(n, d) for n, d in zip(materials.names, materials.values_eur, strict=True)
        )

    def by_class(self, materials: Materials) -> dict[int, float]:
        """EUR per material class id (2, 3, ...)."""
        return dict(zip(materials.ids, self.of_materials(materials), strict=True))

    def of_types(self, catalogue: Catalogue) -> dict[int, float]:
        """{catalogue type index: EUR} of the item types given a value of their own (their
        shape variants, a crushed can of a can type, take it too)."""
        given = self.given()
        out = {}
        for k, t in enumerate(catalogue.types):
            base = t.variant_of or t.name
            if base in given:
                out[k] = given[base]
        return out

    def check_names(self, catalogue: Catalogue, where: str | None) -> None:
        """Refuse a name that is neither a material nor a base item type of `catalogue`."""
        names = set(catalogue.materials.names)
        names |= {t.name for t in catalogue.types if not t.variant_of}
        for name, _ in self.eur:
            allowed = "a material (" + ", ".join(catalogue.materials.names) + ") or item type"
            _check(name in names, f"values.{name}", allowed, None, where)

    def table(self, materials: Materials) -> dict[str, float]:
        """The resolved `[values]` table: every material's value, then the item types'."""
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
            ok = v is None or (isinstance(v, list | tuple) and all(_number(x) for x in v))
            _check(ok, f"flow.{name}", "a list of probabilities", v, None)
            if v is not None:
                object.__setattr__(self, name, tuple(float(x) for x in v))
        v = self.transitions
        ok = v is None or (
            isinstance(v, list | tuple)
            and all(isinstance(r, list | tuple) and all(_number(x) for x in r) for r in v)
        )
        _check(ok, "flow.transitions", "a list of rows of probabilities", v, None)
        if v is not None:
            object.__setattr__(self, "transitions", tuple(tuple(float(x) for x in r) for r in v))

    def flow_kwargs(self) -> dict[str, Any]:
        """The `FlowConfig` keywords set here."""
        names = ("class_priors", "transitions", "stripe_priors")
        return {n: getattr(self, n) for n in names if getattr(self, n) is not None}


@dataclass(frozen=True)
class QLearning:
    """Parameters of the thesis's Q-learning decision manager (3.4.1, 4.2); the rollout planner
    takes them too. The random actions are drawn from the episode's seed."""

    gamma: float = 0.9
    iterations: int = 50
    batch_rows: int = 20
    objective: str = "value_over_distance"

    def __post_init__(self) -> None:
        where = None
        g = self.gamma
        _check(_number(g) and 0.0 <= g < 1.0, "qlearning.gamma", "[0, 1)", g, where)
        n = self.iterations
        _check(_integer(n) and 1 <= n <= 10000, "qlearning.iterations", "1..10000", n, where)
        b = self.batch_rows
        _check(_integer(b) and 1 <= b <= 1000, "qlearning.batch_rows", "1..1000", b, where)
        o = self.objective
        _check(o in OBJECTIVES, "qlearning.objective", " | ".join(OBJECTIVES), o, where)


@dataclass(frozen=True)
class Robot:
    """Extra robot dwell at the pick (after the seal) and at the place (after the release) [s],
    and whether an idle robot sleeps in MuJoCo (`sim.cell.idle_sleep`).

    0 is the physical robot (ABB's 35 ms of vacuum at each end only). The thesis's simulator
    paused about half a second after each pick and each place (4.2); set both to 0.5 to
    reproduce that regime.
    """

    pick_pause_s: float = 0.0
    place_pause_s: float = 0.0
    idle_sleep: bool = True

    def __post_init__(self) -> None:
        for name in ("pick_pause_s", "place_pause_s"):
            v = getattr(self, name)
            _check(_number(v) and 0.0 <= v <= 2.0, f"robot.{name}", "0..2 s", v, None)
        v = self.idle_sleep
        _check(isinstance(v, bool), "robot.idle_sleep", "true | false", v, None)


@dataclass(frozen=True)
class Video:
    """Settings of the episode's MP4 (frames per simulated second, frame size [px])."""

    fps: float = 10.0
    width: int = 640
    height: int = 360

    def __post_init__(self) -> None:
        where = None
        _check(_number(self.fps) and 1 <= self.fps <= 60, "video.fps", "1..60", self.fps, where)
        for name in ("width", "height"):
            v = getattr(self, name)
            ok = _integer(v) and 64 <= v <= 1920 and v % 8 == 0
            _check(ok, f"video.{name}", "64..1920, a multiple of 8", v, where)


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


@dataclass(frozen=True)
class Camera:
    """The belt camera's frame size [px]: the calibration is scaled to it, the stereo depth
    (and its noise, correlated over pixels) comes at it, so coarser frames see coarser items."""

    width: int = FRAME_SIZE[0]
    height: int = FRAME_SIZE[1]

    def __post_init__(self) -> None:
        lo, hi = CAMERA_WIDTH_RANGE
        aw, ah = CAMERA_ASPECT
        w, h = self.width, self.height
        ok = _integer(w) and lo <= w <= hi and w % aw == 0
        _check(ok, "camera.width", f"{lo}..{hi} px, a multiple of {aw}", w, None)
        allowed = f"width x {ah}/{aw} (the calibration's {aw}:{ah}): {w * ah // aw} px"
        _check(_integer(h) and h * aw == w * ah, "camera.height", allowed, h, None)

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) [px]."""
        return (self.width, self.height)


@dataclass(frozen=True)
class Cup:
    """The vacuum cup: its lip's diameter (a model setting: the cell is compiled with it) and
    the vacuum it holds with; the holding force is lip area x vacuum (`sim.cell.suction`)."""

    diameter_m: float = CUP_DIAMETER_M
    vacuum_pa: float = 80e3

    def __post_init__(self) -> None:
        lo, hi = CUP_DIAMETER_RANGE_M
        d = self.diameter_m
        _check(_number(d) and lo <= d <= hi, "cup.diameter_m", f"{lo}..{hi} m", d, None)
        lo, hi = VACUUM_RANGE_PA
        v = self.vacuum_pa
        ok = _number(v) and lo <= v <= hi
        _check(ok, "cup.vacuum_pa", f"{lo:g}..{hi:g} Pa (1 atm)", v, None)


@dataclass(frozen=True)
class Belt:
    """The belt's length from its infeed [m] (a model setting: the cell is compiled with it;
    its discharge end moves, the camera and the robot stay), and whether the infeed holds an
    item back while it would drop into one already there (`sim.episode.infeed`)."""

    length_m: float = BELT_LENGTH_M
    infeed_hold: bool = True

    def __post_init__(self) -> None:
        lo, hi = BELT_LENGTH_RANGE_M
        n = self.length_m
        _check(_number(n) and lo <= n <= hi, "belt.length_m", f"{lo}..{hi} m", n, None)
        v = self.infeed_hold
        _check(isinstance(v, bool), "belt.infeed_hold", "true | false", v, None)


@dataclass(frozen=True)
class EpisodeConfig:
    """One episode of the sorting cell; validated on construction."""

    seed: int = 0
    items: int = 100
    speed_factor: float = 1.0
    planner: str = "qlearning"
    perception: str = "camera"
    duration_s: float = 90.0
    observation_period_s: float = 0.5
    item_riding: str = "path"
    energy_price_eur_per_kwh: float = 0.0
    min_class_confidence: float = 0.0
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
    robots: int = 1
    robot_table: tuple[LineRobotSpec, ...] = ()
    coordination: str = "coordinated"
    catalogue: str = ""
    values: Values = field(default_factory=Values)
    flow: FlowMix = field(default_factory=FlowMix)
    qlearning: QLearning = field(default_factory=QLearning)
    video: Video = field(default_factory=Video)
    robot: Robot = field(default_factory=Robot)
    camera: Camera = field(default_factory=Camera)
    cup: Cup = field(default_factory=Cup)
    belt: Belt = field(default_factory=Belt)
    where: str | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        w = self.where
        _check(_integer(self.seed) and 0 <= self.seed < 2**63, "seed", "0..2^63-1", self.seed, w)
        n = self.items
        _check(_integer(n) and 1 <= n <= MAX_ITEMS, "items", f"1..{MAX_ITEMS}", n, w)
        f = self.speed_factor
        lo, hi = BELT_SPEED_RANGE_MPS
        ok = _number(f) and lo - 1e-9 <= belt_speed_mps(f) <= hi + _SPEED_TOLERANCE_MPS
        x1 = BELT_SPEED_X1_MPS
        allowed = f"{lo / x1:.3f}..1.5 (belt {lo}..{hi} m/s at {x1} m/s per x1)"
        _check(ok, "speed_factor", allowed, f, w)
        _check(isinstance(self.planner, str), "planner", ALLOWED_PLANNERS, self.planner, w)
        try:
            check_planner(self.planner)
        except RefusedInput as exc:
            raise InvalidInput("planner", exc.allowed, self.planner, w) from None
        p = self.perception
        _check(p in PERCEPTIONS, "perception", " | ".join(PERCEPTIONS), p, w)
        d = self.duration_s
        _check(_number(d) and 1.0 <= d <= 36000.0, "duration_s", "1..36000 s", d, w)
        t = self.observation_period_s
        ok = _number(t) and 0.05 <= t <= 5.0
        _check(ok, "observation_period_s", "0.05..5 s", t, w)
        r = self.item_riding
        _check(r in ITEM_RIDINGS, "item_riding", " | ".join(ITEM_RIDINGS), r, w)
        e = self.energy_price_eur_per_kwh
        ok = _number(e) and 0.0 <= e <= MAX_ENERGY_PRICE
        _check(ok, "energy_price_eur_per_kwh", f"0..{MAX_ENERGY_PRICE:g} EUR/kWh", e, w)
        c = self.min_class_confidence
        ok = _number(c) and 0.0 <= c <= 1.0
        _check(ok, "min_class_confidence", "a probability in [0, 1]", c, w)
        k = self.classifier
        _check(k in CLASSIFIERS, "classifier", " | ".join(CLASSIFIERS), k, w)
        _check(
            isinstance(self.depth_noise, bool), "depth_noise", "true | false", self.depth_noise, w
        )
        for name, cls in _SECTIONS.items():
            _check(isinstance(getattr(self, name), cls), name, f"a [{name}] table", None, w)
        _check(self.world in WORLDS, "world", " | ".join(WORLDS), self.world, w)
        for name in WORLD_NUMBERS:
            v = getattr(self, name)
            _check(v is None or _number(v), name, "a number", v, w)
        try:
            _ = self.world_variation
        except InvalidInput as exc:
            raise InvalidInput(exc.field, exc.allowed, exc.got, w) from None
        r = self.robots
        _check(_integer(r) and 1 <= r <= MAX_ROBOTS, "robots", f"1..{MAX_ROBOTS}", r, w)
        ok = isinstance(self.robot_table, tuple | list)
        _check(ok, "robots", "a count or an array of [[robots]] tables", self.robot_table, w)
        table = tuple(self.robot_table)
        ok = not table or len(table) == r
        _check(ok, "robots", f"as many robots as [[robots]] tables ({len(table)})", r, w)
        object.__setattr__(self, "robot_table", table)
        c = self.coordination
        _check(c in COORDINATIONS, "coordination", " | ".join(COORDINATIONS), c, w)
        ok = isinstance(self.catalogue, str) and "\0" not in self.catalogue
        _check(ok, "catalogue", "a path to an item catalogue TOML file", self.catalogue, w)
        try:
            catalogue = self.item_catalogue
        except InvalidInput as exc:
            raise InvalidInput(exc.field, exc.allowed, exc.got, exc.where or w) from None
        self.values.check_names(catalogue, w)
        check_robots_table(self.robot_table, catalogue.materials, w)
        # Every material's value written out (the catalogue's where not given), so configs
        # compare equal by what they run with, and a manifest's table reads back the same.
        resolved = Values.from_table(self.values.table(catalogue.materials))
        object.__setattr__(self, "values", resolved)
        self._check_flow()

    @property
    def item_catalogue(self) -> Catalogue:
        """The item catalogue (`catalogue`; the default when "")."""
        return episode_catalogue(self.catalogue)

    @property
    def materials(self) -> Materials:
        """The catalogue's materials: the classes, one bin each."""
        return self.item_catalogue.materials

    def flow_config(self) -> FlowConfig:
        """The episode's flow settings."""
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
        return tuple(s.x_m for s in self.robot_table if s.x_m is not None)

    @functools.cached_property
    def robot_class_ids(self) -> tuple[frozenset[int] | None, ...]:
        """Per robot, upstream first, the material class ids (2, 3, ...) it sorts; None: every
        material (`planner.decision.robot_materials`)."""
        names = [s.materials for s in self.robot_table] or [None] * self.robots
        return tuple(class_ids_of(n, self.materials) for n in names)

    @property
    def line_cell(self) -> bool:
        """Whether the episode runs on a line's model (`sim.cell.line`): several robots, one
        robot placed elsewhere than x = 0, or one robot on a belt denser than the single
        cell's pool carries (`MAX_ITEMS_PER_METRE`)."""
        if self.robots > 1 or self.robot_positions_m[:1] not in ((), (0.0,)):
            return True
        density = self.items / (self.duration_s * self.belt_speed_mps)
        return density > MAX_ITEMS_PER_METRE * (1 + 1e-9)

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
        return CellSettings(self.cup.diameter_m, self.belt.length_m)

    @property
    def belt_speed_mps(self) -> float:
        """Belt speed of this episode [m/s]."""
        return belt_speed_mps(self.speed_factor)

    def replace(self, **changes: Any) -> EpisodeConfig:
        """A copy with `changes` applied (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of every setting (TOML layout), for reports and sweep keys."""
        out = dataclasses.asdict(self)
        out.pop("where")
        out.pop("robot_table")
        if self.robot_table:
            out["robots"] = [spec.table() for spec in self.robot_table]
        out["values"] = self.values.table(self.materials)
        out["flow"] = {k: _plain(v) for k, v in self.flow.flow_kwargs().items()}
        return out


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
    "robot": Robot,
    "camera": Camera,
    "cup": Cup,
    "belt": Belt,
}
_SCALARS = {f.name for f in dataclasses.fields(EpisodeConfig)} - set(_SECTIONS)
_SCALARS -= {"where", "robot_table"}  # the table comes as `robots = [...]`


def from_dict(data: dict[str, Any], where: str | None = None) -> EpisodeConfig:
    """An `EpisodeConfig` from a TOML-shaped dict; unknown keys refused naming `where`."""
    try:
        return _from_dict(data, where)
    except InvalidInput as exc:
        if exc.where is None and where is not None:
            raise InvalidInput(exc.field, exc.allowed, exc.got, where) from None
        raise


def _from_dict(data: dict[str, Any], where: str | None) -> EpisodeConfig:
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        if key in _SECTIONS:
            cls = _SECTIONS[key]
            _check(isinstance(value, dict), key, "a table [" + key + "]", value, where)
            if cls is Values:
                kwargs[key] = Values.from_table(value)
                continue
            names = {f.name for f in dataclasses.fields(cls)}
            for sub in value:
                _check(
                    sub in names, f"{key}.{sub}", "one of " + ", ".join(sorted(names)), None, where
                )
            kwargs[key] = cls(**value)
        elif key == "robots" and isinstance(value, list | tuple):
            kwargs["robot_table"] = robots_table(value, MAX_ROBOTS, where)
            kwargs["robots"] = len(value)
        else:
            allowed = "one of " + ", ".join(sorted(_SCALARS | set(_SECTIONS)))
            _check(key in _SCALARS, key, allowed, None, where)
            kwargs[key] = value
    return EpisodeConfig(where=where, **kwargs)


def read_config_file(path: Path) -> dict[str, Any]:
    """The settings of a config file: a TOML file, or a run folder's `manifest.json` (its
    resolved `config`), so that `sortsim run --config runs/x/manifest.json` repeats that run.
    A manifest whose catalogue's content has changed since is refused (`catalogue_digest`)."""
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
    """Parsed TOML of `path`; a missing, unreadable, non-UTF-8 or malformed file is refused in
    one line naming the file."""
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
    """The episode config of TOML `path` (or defaults) with non-None `overrides` applied."""
    data = read_config_file(path) if path is not None else {}
    where = str(path) if path is not None else None
    config = from_dict(data, where)
    changes = {k: v for k, v in overrides.items() if v is not None}
    unknown = set(changes) - _SCALARS
    _check(not unknown, "override", ", ".join(sorted(_SCALARS)), sorted(unknown), None)
    if "robots" in changes:  # a robot count replaces the file's [[robots]] table
        changes["robot_table"] = ()
    return dataclasses.replace(config, where=None, **changes) if changes else config
