"""`EpisodeConfig`: the validated, frozen config of one episode: the top-level keys
(`sim.config.settings`), the tables (`sim.config.sections`, `values`, `flow_table`), the
faults (`sim.config.faults`) and the rules between keys (the catalogue's names, the belt's
speed and the feed in one unit, the flow's density at its peak, the faults on the cell's
parts within the episode). Built by the loaders (`sim.config.loading`), which read the files."""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from typing import Any

from perception.codes import Materials
from planner.decision.registry import ALLOWED as ALLOWED_PLANNERS
from planner.decision.registry import check_planner
from planner.decision.robot_materials import class_ids_of
from planner.motion.belt_speeds import SPEED_X1_MPS
from sim.checks import check, is_integer
from sim.config.catalogue_file import CatalogueFile, builtin_catalogue
from sim.config.faults import (
    Fault,
    FaultSchedule,
    RandomFaults,
    draw_schedule,
    fault_tables,
    faults_of_tables,
    random_faults_of_table,
    random_faults_table,
)
from sim.config.fields import validate
from sim.config.flow_table import FlowMix
from sim.config.plant import MAX_ROBOTS, VACUUM_RANGE_PA, CellSettings, default_cup_diameter_m
from sim.config.robots import RobotSpec, check_count, check_robots, resized
from sim.config.sections import (
    Belt,
    Camera,
    Cup,
    Economics,
    Hmm,
    InfeedRate,
    QLearning,
    Surges,
    Timeline,
    Video,
)
from sim.config.settings import (
    DEFAULT_ITEMS,
    DEFAULT_SPEED_FACTOR,
    MAX_ITEMS,
    WORLD_NUMBERS,
    EpisodeSettings,
    belt_speed_mps,
    default_min_confidence,
)
from sim.config.values import Values
from sim.errors import InvalidInput, RefusedInput
from sim.flow import feed_rate
from sim.flow import mix as flow_mix
from sim.flow.catalogue import DEFAULT_CATALOGUE, Catalogue
from sim.flow.config import STRIPE_WIDTH, FlowConfig, default_transitions
from sim.flow.feed_rate import FEED_KEYS
from sim.flow.generator import EDGE_MARGIN_M
from sim.flow.limits import LINE_MAX_ITEMS_PER_METRE, MAX_ITEMS_PER_METRE
from sim.flow.rate_profile import RateProfile, draw_surges
from sim.flow.world import WorldVariation, check_varied


@dataclass(frozen=True)
class EpisodeConfig(EpisodeSettings):
    """One episode of the sorting cell (or line); validated on construction.

    Every attribute but `catalogue_file` and `where` is a key of the config file (module
    docstring, where each is described with its unit and range). Build one with `load` or
    `from_dict` (which read the catalogue file), `EpisodeConfig.build` (the same from keyword
    fields), `EpisodeConfig()` with fields (the built-in catalogue only: it reads no file) or
    `config.replace(...)`.

    Attributes:
        robots: The robots, upstream first (1..`MAX_ROBOTS` `RobotSpec`s). Constructing with an
            int N gives N robots at the default spacing with the default pauses;
            `config.replace(robots=N)` keeps the pauses (`sim.config.robots.resized`).
        catalogue: The item catalogue's file as the config names it ("": the built-in one);
            what a manifest records.
        faults: The faults given (`[[faults]]` tables; `sim.config.faults.Fault`).
        faults_random: The faults drawn by seed (`[faults_random.<kind>]` tables of
            `mtbf_s`, `mttr_s` and the kind's keys; `sim.config.faults.RandomFaults`).
        catalogue_file: That file's catalogue, read by the loaders (None: the built-in one,
            for a config of `catalogue = ""` only); compared by its content digest.
        where: The config file the settings came from, named by every refusal (not compared).
    """

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
    timeline: Timeline = field(default_factory=Timeline)
    faults: tuple[Fault, ...] = ()
    faults_random: tuple[RandomFaults, ...] = ()
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
        self._check_rate_profile()
        self._check_faults()

    def _resolve_belt_speed(self) -> None:
        """`speed_factor` of a `[belt] speed_mps`: the speed over x1 (a factor given too is
        refused unless it is that one)."""
        v = self.belt.speed_mps
        if v is None:
            return
        derived = v / SPEED_X1_MPS
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
        """The settings that need no catalogue: the keys' own ranges and choices, the planner,
        the tables' types, the world."""
        w = self.where
        validate(self, "", w)
        check(isinstance(self.planner, str), "planner", ALLOWED_PLANNERS, self.planner, w)
        try:
            check_planner(self.planner)
        except RefusedInput as exc:
            raise InvalidInput("planner", exc.allowed, self.planner, w) from None
        for name, cls in SECTIONS.items():
            check(isinstance(getattr(self, name), cls), name, f"a [{name}] table", None, w)
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
        assert loaded is not None
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
        assert self.catalogue_file is not None  # set when the config loads
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
            rate_profile=self.rate_profile,
            **self.mix_kwargs,
        )

    @property
    def rate_profile(self) -> RateProfile:
        """The feed's rate over time (`sim.flow.rate_profile`): the `[infeed] profile`, times
        the surges drawn from the episode's seed over `duration_s` when `[infeed] surges` is
        set; empty: a steady feed (the flow of old, to the bit)."""
        given = RateProfile(self.rate_steps)
        if self.surges is None:
            return given
        s = self.surges
        drawn = draw_surges(self.seed, s.mean_gap_s, s.mean_length_s, s.factor, self.duration_s)
        return given.combined(drawn)

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
        """Whether the episode's cell has a line's item pool (`sim.model.line_model.pool_capacity`):
        several robots, one robot placed elsewhere than x = 0, or one robot on a belt denser
        than the single cell's pool carries (`MAX_ITEMS_PER_METRE`) at the feed's peak."""
        if self.robot_count > 1 or self.robot_positions_m[:1] not in ((), (0.0,)):
            return True
        density = self.items / (self.duration_s * self.belt_speed_mps)
        return density * self.peak_rate_factor > MAX_ITEMS_PER_METRE * (1 + 1e-9)

    @property
    def applied_min_class_confidence(self) -> float:
        """The confidence rule's threshold the episode applies, in [0, 1]: `min_class_confidence`
        when set, else the classifier's own (`sim.config.settings.default_min_confidence`:
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

    @property
    def camera_count(self) -> int:
        """The cell's belt cameras: one per robot on a line with `[camera] per_robot` and camera
        perception, else the one (`sim.episode.runner`)."""
        per_robot = self.camera.per_robot and self.perception == "camera"
        return self.robot_count if per_robot else 1

    @property
    def end_s(self) -> float:
        """The episode's end for its faults [s]: `horizon_s` when set, else `duration_s`."""
        return float(self.horizon_s if self.horizon_s is not None else self.duration_s)

    def fault_schedule(self) -> FaultSchedule:
        """The episode's faults: the given and those drawn from its seed over [0, `end_s`)
        (`sim.config.faults.draw_schedule`), checked against the cell's robots and cameras."""
        return self._fault_schedule

    @functools.cached_property
    def _fault_schedule(self) -> FaultSchedule:
        robots, cameras, end = self.robot_count, self.camera_count, self.end_s
        schedule = draw_schedule(self.faults, self.faults_random, self.seed, robots, cameras, end)
        schedule.check_cell(robots, cameras, end)
        return schedule

    def _check_faults(self) -> None:
        """The faults as `Fault`s and `RandomFaults` (from a file's tables), each vacuum a drop
        from the cup's, and the schedule drawn and checked now: a bad list is refused at load."""
        try:
            object.__setattr__(self, "faults", faults_of_tables(self.faults))
            object.__setattr__(self, "faults_random", random_faults_of_table(self.faults_random))
            lo, hi = VACUUM_RANGE_PA[0], self.cup.vacuum_pa
            allowed = f"{lo:g}..{hi:g} Pa (a drop from the cup's vacuum_pa)"
            for key, group in (("faults", self.faults), ("faults_random", self.faults_random)):
                for pa in (f.vacuum_pa for f in group if f.vacuum_pa is not None):
                    check(lo <= pa <= hi, f"{key}.vacuum_drop.vacuum_pa", allowed, pa)
            self.fault_schedule()
        except InvalidInput as exc:
            raise InvalidInput(exc.field, exc.allowed, exc.got, exc.where or self.where) from None

    @property
    def rate_steps(self) -> tuple[tuple[float, float], ...]:
        """The feed's rate profile: (start_s [s], factor) pairs, starts ascending (`[infeed]
        profile`; the factor is 1 before the first); (): a steady feed."""
        return self.infeed.profile

    @property
    def surges(self) -> Surges | None:
        """The surges drawn by seed over the feed (`[infeed] surges`); None: none."""
        return self.infeed.surges

    @property
    def peak_rate_factor(self) -> float:
        """The feed's highest factor of its rate: the profile's (1 before its first step)
        times a surge's when it is above 1."""
        steps = self.rate_steps
        factors = [f for _, f in steps]
        if not steps or steps[0][0] > 0:
            factors.append(1.0)
        surge = self.surges.factor if self.surges is not None else 1.0
        return max(factors) * max(surge, 1.0)

    def _check_rate_profile(self) -> None:
        """Refuse a profile stepping at or after `duration_s` (the feed ends then), feeding
        no item or more than `MAX_ITEMS`, or a feed denser at its peak than the belt takes."""
        steps, w = self.rate_steps, self.where
        if not steps and self.surges is None:
            return
        d = float(self.duration_s)
        allowed = f"steps starting before duration_s ({d:g} s: the feed ends then)"
        check(all(t < d for t, _ in steps), "infeed.profile", allowed, steps, w)
        mean = _mean_factor(steps, d)
        count = round(self.items * mean)
        allowed = f"a profile feeding 1..{MAX_ITEMS} items ({self.items} x its mean factor)"
        check(1 <= count <= MAX_ITEMS, "infeed.profile", allowed, steps, w)
        base = self.items / (d * self.belt_speed_mps)
        most = self.max_items_per_metre
        belt = f"the belt takes {most:g} items per metre; the feed is {base:.4g} items/m"
        top = max([f for _, f in steps] + [1.0])
        allowed = f"factors of at most {most / base:.4g} ({belt})"
        check(base * top <= most * (1 + 1e-9), "infeed.profile", allowed, steps, w)
        if self.surges is not None:
            ok = base * self.peak_rate_factor <= most * (1 + 1e-9)
            allowed = f"at most {most / base / top:.4g} ({belt}, x{top:g} at the profile's peak)"
            check(ok, "infeed.surges.factor", allowed, self.surges.factor, w)

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
        robots' default (`sim.config.plant.default_cup_diameter_m`: 0.06 for one robot,
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
                spacing, each keeping its pauses (`sim.config.robots.resized`); a new
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
        out["faults"] = fault_tables(self.faults)
        out["faults_random"] = random_faults_table(self.faults_random)
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
            rates = dict.fromkeys(FEED_KEYS)
            out["infeed"] = infeed = dataclasses.replace(infeed, **rates)
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


def _mean_factor(steps: tuple[tuple[float, float], ...], duration_s: float) -> float:
    """The mean of a rate profile's factor over [0, duration_s) (1 before its first step)."""
    edges = [0.0, *(t for t, _ in steps), duration_s]
    factors = [1.0, *(f for _, f in steps)]
    total = sum(
        f * max(0.0, min(b, duration_s) - a)
        for f, a, b in zip(factors, edges, edges[1:], strict=False)
    )
    return total / duration_s


def _is_table(value: Any) -> bool:
    """Whether `value` is a section's dataclass (written as a TOML table)."""
    return dataclasses.is_dataclass(value) and not isinstance(value, type)


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


SECTIONS = {
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
    "timeline": Timeline,
}
"""The tables of a config file, by key."""
FAULT_KEYS = ("faults", "faults_random")
"""The faults' keys of a config file: `[[faults]]` (an array of tables) and `[faults_random]`
(a table of tables by kind), read by `sim.config.faults`."""
SCALARS = tuple(f.name for f in dataclasses.fields(EpisodeSettings))
"""The top-level keys of a config file (`robots` a count or an array of tables)."""
