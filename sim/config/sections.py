"""The tables of an episode config that stand alone: `[qlearning]`, `[video]`, `[camera]`,
`[cup]`, `[belt]`, `[infeed]` (its `surges`), `[hmm]`, `[economics]` and `[timeline]`. Each
key's range is its field's `Setting` (`sim.config.fields`); a table checks itself on
construction (`validate`), plus the rules that tie two of its keys. Nothing heavy is imported.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from planner.motion.belt_speeds import SPEED_RANGE_MPS, SPEED_TOLERANCE_MPS, SPEED_X1_MPS
from sim.checks import check, is_finite_number, is_integer
from sim.config.fields import Range, check_keys, setting, validate
from sim.config.plant import (
    BELT_LENGTH_M,
    BELT_LENGTH_RANGE_M,
    CAMERA_ASPECT,
    CAMERA_WIDTH_RANGE,
    CUP_DIAMETER_RANGE_M,
    FRAME_SIZE,
    VACUUM_RANGE_PA,
)
from sim.flow.feed_rate import FEED_KEYS, SECONDS_PER_HOUR
from sim.flow.limits import (
    BELT_WIDTH_M,
    BELT_WIDTH_RANGE_M,
    LINE_MAX_ITEMS_PER_METRE,
    MASS_RANGE_KG,
)

SPEED_TOLERANCE = SPEED_TOLERANCE_MPS + 1e-12
"""How far past its range the belt's own check takes a speed [m/s] (x1.5 = 0.2775 m/s rounds
to the conveyor's 0.277 m/s), to the bit."""
OBJECTIVES = ("value_over_distance", "value_only", "distance_only")
MAX_ENERGY_PRICE = 1e6
"""Highest energy price accepted [EUR/kWh] (far above any tariff: a stress test's price)."""
ENERGY_PRICE = Range(0.0, MAX_ENERGY_PRICE, f"0..{MAX_ENERGY_PRICE:g} EUR/kWh")
"""The energy price's range, top-level or in `[economics]`."""
MIN_FEED_RATE = 0.01
"""Smallest feed rate of an `[infeed]` key (items/m, items/s, kg/h)."""
MAX_ITEMS_PER_S = LINE_MAX_ITEMS_PER_METRE * 1.5 * SPEED_X1_MPS
"""Fastest item rate: the densest belt at the belt's top speed (x1.5) [items/s]."""
MAX_KG_PER_H = round(MAX_ITEMS_PER_S * SECONDS_PER_HOUR * MASS_RANGE_KG[1], 3)
"""Largest mass rate: the fastest item rate of the heaviest items a catalogue may hold
[kg/h] (the catalogue's mean item mass decides: the belt's loading is checked with it)."""
MAX_RATE_FACTOR = 100.0
"""Largest factor of the feed's rate a profile's step or a surge may give (the belt's density
at the peak is checked too: `sim.config.episode`)."""
RATE_FACTOR = Range(0.0, MAX_RATE_FACTOR, f"0..{MAX_RATE_FACTOR:g}, the belt's density permitting")
_VIDEO_SIDE = Range(64, 1920, "64..1920, a multiple of 8", integer=True, multiple=8)


def _between(lo: float, hi: float, unit: str) -> Range:
    return Range(lo, hi, f"{lo:g}..{hi:g} {unit}")


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

    gamma: float = setting(0.9, range=Range(0.0, 1.0, "[0, 1)", hi_open=True))
    iterations: int = setting(50, range=Range(1, 10000, "1..10000", integer=True))
    batch_rows: int = setting(20, range=Range(1, 1000, "1..1000", integer=True))
    objective: str = setting("value_over_distance", choices=OBJECTIVES)

    def __post_init__(self) -> None:
        validate(self, "qlearning.")


@dataclass(frozen=True)
class Video:
    """Settings of the episode's MP4.

    Attributes:
        fps: Frames per simulated second, 1..60.
        width: Frame width [px], 64..1920, a multiple of 8.
        height: Frame height [px], 64..1920, a multiple of 8.
    """

    fps: float = setting(10.0, range=Range(1.0, 60.0, "1..60"))
    width: int = setting(640, range=_VIDEO_SIDE)
    height: int = setting(360, range=_VIDEO_SIDE)

    def __post_init__(self) -> None:
        validate(self, "video.")


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

    width: int = setting(
        FRAME_SIZE[0],
        range=Range(
            *CAMERA_WIDTH_RANGE,
            f"{CAMERA_WIDTH_RANGE[0]}..{CAMERA_WIDTH_RANGE[1]} px, a multiple of "
            f"{CAMERA_ASPECT[0]}",
            integer=True,
            multiple=CAMERA_ASPECT[0],
        ),
    )
    height: int = FRAME_SIZE[1]
    per_robot: bool = setting(False, boolean=True)

    def __post_init__(self) -> None:
        validate(self, "camera.")
        aw, ah = CAMERA_ASPECT
        w, h = self.width, self.height
        allowed = f"width x {ah}/{aw} (the calibration's {aw}:{ah}): {w * ah // aw} px"
        check(is_integer(h) and h * aw == w * ah, "camera.height", allowed, h, None)

    @property
    def size(self) -> tuple[int, int]:
        """The frame size, (width, height) [px]."""
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

    diameter_m: float | None = setting(
        range=Range(
            *CUP_DIAMETER_RANGE_M, f"{CUP_DIAMETER_RANGE_M[0]}..{CUP_DIAMETER_RANGE_M[1]} m"
        )
    )
    vacuum_pa: float = setting(
        80e3,
        range=Range(*VACUUM_RANGE_PA, f"{VACUUM_RANGE_PA[0]:g}..{VACUUM_RANGE_PA[1]:g} Pa (1 atm)"),
    )

    def __post_init__(self) -> None:
        validate(self, "cup.")


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

    length_m: float = setting(
        BELT_LENGTH_M,
        range=Range(*BELT_LENGTH_RANGE_M, f"{BELT_LENGTH_RANGE_M[0]}..{BELT_LENGTH_RANGE_M[1]} m"),
    )
    infeed_hold: bool = setting(True, boolean=True)
    speed_mps: float | None = setting(
        range=Range(
            *SPEED_RANGE_MPS,
            f"{SPEED_RANGE_MPS[0]}..{SPEED_RANGE_MPS[1]} m/s (the conveyor's range)",
            slack=(1e-9, SPEED_TOLERANCE),
        ),
        to_float=True,
        option="--belt-speed",
        keyword="belt_speed_mps",
        metavar="M/S",
        help="belt speed in m/s, {lo}..{hi}, instead of --speed-factor (the config's [belt] "
        "speed_mps)",
    )
    width_m: float = setting(
        BELT_WIDTH_M,
        range=Range(*BELT_WIDTH_RANGE_M, f"{BELT_WIDTH_RANGE_M[0]}..{BELT_WIDTH_RANGE_M[1]} m"),
    )

    def __post_init__(self) -> None:
        validate(self, "belt.")


@dataclass(frozen=True)
class Surges:
    """Surges of material over the feed, drawn from the episode's seed
    (`sim.flow.rate_profile.draw_surges`): the gaps between surges and their lengths
    exponential, the feed's rate times `factor` during each (a tipping floor emptied onto the
    infeed). Every key is required.

    Attributes:
        mean_gap_s: Mean time from one surge's end to the next's start [s].
        mean_length_s: Mean length of a surge [s].
        factor: The feed's rate during a surge, as a factor of its rate (below 1: a lull).
    """

    mean_gap_s: float = setting(range=_between(1.0, 36000.0, "s"), to_float=True)
    mean_length_s: float = setting(range=_between(1.0, 36000.0, "s"), to_float=True)
    factor: float = setting(range=RATE_FACTOR, to_float=True)

    def __post_init__(self) -> None:
        for name in ("mean_gap_s", "mean_length_s", "factor"):
            allowed = "a value: every key of infeed.surges is required"
            check(getattr(self, name) is not None, f"infeed.surges.{name}", allowed, None)
        validate(self, "infeed.surges.")


PROFILE_ALLOWED = (
    f"a list of [start_s, factor] pairs: start_s >= 0 s, ascending; factor {RATE_FACTOR.allowed}"
)


def rate_steps(steps: Any) -> tuple[tuple[float, float], ...]:
    """An `[infeed] profile` as (start_s [s], factor) pairs of floats, refused in one line
    unless a list of pairs, the starts >= 0 and ascending, each factor in `RATE_FACTOR`."""
    ok = isinstance(steps, list | tuple) and all(
        isinstance(p, list | tuple) and len(p) == 2 and all(is_finite_number(x) for x in p)
        for p in steps
    )
    check(ok, "infeed.profile", PROFILE_ALLOWED, steps)
    starts = [p[0] for p in steps]
    ok = all(t >= 0 for t in starts) and all(
        b > a for a, b in zip(starts, starts[1:], strict=False)
    )
    ok = ok and all(RATE_FACTOR.allows(p[1]) for p in steps)
    check(ok, "infeed.profile", PROFILE_ALLOWED, steps)
    return tuple((float(t), float(f)) for t, f in steps)


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
        profile: The feed's rate over time: [[start_s, factor], ...], the rate (of `items` or
            the key above) times the factor from each start on [s], 1 before the first (surges
            and gaps; `sim.flow.rate_profile`). Empty: a steady feed.
        surges: Surges drawn by seed (`Surges`: `{ mean_gap_s, mean_length_s, factor }`), their
            factor multiplying the profile's. Unset: none.
    """

    items_per_m: float | None = setting(
        range=Range(
            MIN_FEED_RATE,
            LINE_MAX_ITEMS_PER_METRE,
            f"{MIN_FEED_RATE:g}..{LINE_MAX_ITEMS_PER_METRE:g} items per metre of belt",
        ),
        to_float=True,
        option="--items-per-m",
        metavar="N",
        help="the feed as items per metre of belt, {lo:g}..{hi:g}, instead of --items: N x "
        "belt speed x --duration items, rounded (the config's [infeed] items_per_m)",
    )
    items_per_s: float | None = setting(
        range=Range(
            MIN_FEED_RATE,
            MAX_ITEMS_PER_S,
            f"{MIN_FEED_RATE:g}..{MAX_ITEMS_PER_S:g} items/s ({LINE_MAX_ITEMS_PER_METRE:g} per "
            "metre of belt at its top speed)",
        ),
        to_float=True,
    )
    kg_per_h: float | None = setting(
        range=Range(
            MIN_FEED_RATE,
            MAX_KG_PER_H,
            f"{MIN_FEED_RATE:g}..{MAX_KG_PER_H:g} kg/h ({MAX_ITEMS_PER_S:g} items/s of "
            f"{MASS_RANGE_KG[1]:g} kg)",
        ),
        to_float=True,
    )
    profile: tuple[tuple[float, float], ...] = setting(())
    surges: Surges | None = setting()

    def __post_init__(self) -> None:
        given = [k for k in FEED_KEYS if getattr(self, k) is not None]
        allowed = "one of " + ", ".join(FEED_KEYS) + " (a rate), not several"
        check(len(given) <= 1, "infeed", allowed, given, None)
        validate(self, "infeed.")
        object.__setattr__(self, "profile", rate_steps(self.profile))
        if isinstance(self.surges, dict):
            check_keys(Surges, self.surges, "infeed.surges.", None)
            object.__setattr__(self, "surges", Surges(**self.surges))
        allowed = "a table { mean_gap_s = S, mean_length_s = S, factor = F }"
        ok = self.surges is None or isinstance(self.surges, Surges)
        check(ok, "infeed.surges", allowed, self.surges)

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

    coupled: bool = setting(False, boolean=True)

    def __post_init__(self) -> None:
        validate(self, "hmm.")


def robot_cost_per_h(
    capital_eur: float, life_years: float, hours_per_year: float, maintenance_eur_per_year: float
) -> float:
    """One robot's cost per running hour [EUR/h]: its capital [EUR] written off straight-line
    over its life's [years] running hours [h/year] (no interest), plus its maintenance
    [EUR/year] over the year's hours."""
    return capital_eur / (life_years * hours_per_year) + maintenance_eur_per_year / hours_per_year


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

    robot_capital_eur: float = setting(75000.0, range=_between(0.0, 1e9, "EUR"))
    robot_life_years: float = setting(10.0, range=_between(1.0, 50.0, "years"))
    hours_per_year: float = setting(4000.0, range=_between(1.0, 8784.0, "h (366 days x 24 h)"))
    robot_maintenance_eur_per_year: float = setting(3000.0, range=_between(0.0, 1e8, "EUR"))
    energy_price_eur_per_kwh: float | None = setting(range=ENERGY_PRICE)

    def __post_init__(self) -> None:
        validate(self, "economics.")

    @property
    def robot_cost_per_h_eur(self) -> float:
        """One robot's cost per running hour [EUR/h] (`robot_cost_per_h`)."""
        return robot_cost_per_h(
            self.robot_capital_eur,
            self.robot_life_years,
            self.hours_per_year,
            self.robot_maintenance_eur_per_year,
        )


@dataclass(frozen=True)
class Timeline:
    """The episode's timeline: `timeline.csv` beside episodes.csv, one row of the counts, the
    robots' states and the active faults every `period_s` (`sim.results.timeline`).

    Attributes:
        period_s: Simulated time between two rows [s].
    """

    period_s: float = setting(10.0, range=_between(0.5, 3600.0, "s"), to_float=True)

    def __post_init__(self) -> None:
        validate(self, "timeline.")
