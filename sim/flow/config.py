"""Settings of a material flow (thesis 2.2.6) and the belt/grid geometry the flow relies on.

Time and row convention, shared with perception: belt speed v constant per episode, observation
period T. An item dropped at the infeed X_INFEED at time t crosses the camera line X_CAMERA at
tau = t + (X_CAMERA - X_INFEED) / v. Row k of the grid is the belt under the camera band
[X_CAMERA - vT/2, X_CAMERA + vT/2) at time k T, so an item's centre belongs to row
round(tau / T). Stripe j (0..4) of a belt of width W covers y in [-W/2 + j W/5, -W/2 +
(j + 1) W/5), stripe 0 on the -y side: [-0.4 + 0.16 j, -0.4 + 0.16 (j + 1)) on the thesis's
0.8 m belt (`BELT_WIDTH_M`, the default; `[belt] width_m` of an episode config).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from planner.motion.belt_speeds import SPEED_RANGE_MPS as BELT_SPEED_RANGE_MPS
from planner.motion.belt_speeds import SPEED_TOLERANCE_MPS
from planner.motion.belt_speeds import SPEED_X1_MPS as BELT_SPEED_X1_MPS
from sim.checks import is_finite_in
from sim.errors import InvalidInput
from sim.flow.limits import (
    BELT_HALF_WIDTH,
    BELT_WIDTH_M,
    BELT_WIDTH_RANGE_M,
    BELT_X_RANGE,
    MAX_ITEMS_PER_METRE,
)
from sim.flow.rate_profile import RateProfile
from sim.flow.world import WorldVariation

X_INFEED = -2.75
X_CAMERA = -1.48
X_DISCHARGE = BELT_X_RANGE[1]
OBSERVATION_PERIOD_S = 0.5
N_STRIPES = 5
STRIPE_WIDTH = 2 * BELT_HALF_WIDTH / N_STRIPES
ITEM_CLASSES = (2, 3, 4)
# x1.5 = 0.2775 m/s is the conveyor's top speed of 0.277 m/s, rounded.
_SPEED_SLACK_MPS = SPEED_TOLERANCE_MPS + 1e-12  # the belt's own check, to the bit

DEFAULT_STRIPE_PRIORS = (0.16, 0.22, 0.24, 0.22, 0.16)
# Rows: previous item's class in the same stripe (paper, plastic, aluminium); columns: next.
# Items of a kind come in clumps (one bin emptied at a time), hence the heavier diagonal.
DEFAULT_TRANSITIONS = (
    (0.46, 0.30, 0.24),
    (0.22, 0.50, 0.28),
    (0.20, 0.28, 0.52),
)
# Near the stationary distribution of DEFAULT_TRANSITIONS, and near the thesis's table 4.3
# (35 paper, 42 plastic, 41 aluminium of 118 items).
DEFAULT_CLASS_PRIORS = (0.29, 0.36, 0.35)
CLUMPING = 0.5
"""P(next item of a stripe has the previous one's class) of the default transitions of a
catalogue with other than the thesis's three materials (the rest spread evenly)."""


def default_class_priors(n_materials: int) -> tuple[float, ...]:
    """The thesis's priors for three materials; equal shares for any other number."""
    if n_materials == 3:
        return DEFAULT_CLASS_PRIORS
    return tuple([1.0 / n_materials] * n_materials)


def default_transitions(n_materials: int) -> tuple[tuple[float, ...], ...]:
    """The thesis-like clumped transitions for three materials; for n others, `CLUMPING` on
    the diagonal and the rest spread evenly (one material alone: always itself)."""
    if n_materials == 3:
        return DEFAULT_TRANSITIONS
    if n_materials == 1:
        return ((1.0,),)
    off = (1.0 - CLUMPING) / (n_materials - 1)
    return tuple(
        tuple(CLUMPING if i == j else off for j in range(n_materials)) for i in range(n_materials)
    )


def stripe_of(y: np.ndarray | float, belt_width_m: float = BELT_WIDTH_M) -> np.ndarray:
    """Stripe index 0..4 of lateral positions y [m] (clipped to the belt) on a belt
    `belt_width_m` [m] wide."""
    half, stripe = stripe_geometry(belt_width_m)
    index = np.floor((np.asarray(y) + half) / stripe).astype(int)
    return np.clip(index, 0, N_STRIPES - 1)


def stripe_geometry(belt_width_m: float = BELT_WIDTH_M) -> tuple[float, float]:
    """(half the belt's width, a stripe's width) [m] of a belt `belt_width_m` [m] wide; the
    thesis's (`BELT_HALF_WIDTH`, `STRIPE_WIDTH`) to the bit for its 0.8 m."""
    half = 0.5 * float(belt_width_m)
    return half, 2 * half / N_STRIPES


def _probabilities(field: str, values, shape: tuple[int, ...]) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    ok: bool | np.bool_ = array.shape == shape and np.all(np.isfinite(array)) and np.all(array >= 0)
    ok = ok and np.allclose(array.sum(axis=-1), 1.0, atol=1e-6)
    if not ok:
        rows = "rows each " if len(shape) > 1 else ""
        allowed = f"{'x'.join(map(str, shape))} non-negative numbers, {rows}summing to 1"
        raise InvalidInput(field, allowed, values)
    return array


@dataclass(frozen=True)
class FlowConfig:
    """One material flow, validated on construction.

    Attributes:
        n_items: Items dropped on the belt.
        duration_s: Time over which they arrive [s] (~90 s in the thesis's tables 4.2, 4.3).
        speed_factor: Belt speed over x1 = 0.185 m/s; any speed inside the conveyor's range
            0.135..0.277 m/s (x1, x1.2 and x1.5 are the thesis's).
        stripe_priors: Probability that an item falls in each of the 5 stripes.
        transitions: n x n row-stochastic matrix P(next class | previous class) along the
            belt within a stripe, classes in the catalogue's material order (paper, plastic,
            aluminium by default); None: `default_transitions(n_materials)`.
        class_priors: Class probabilities of the first item of each stripe (n); None:
            `default_class_priors(n_materials)`.
        seed: Seed of `numpy.random.default_rng`.
        observation_period_s: Grid row period T [s].
        world: How items vary from their catalogue types (sizes, variants, colours, gaps);
            `WorldVariation.uniform()` for the uniform world.
        n_materials: Material classes of the catalogue the flow is drawn from (n).
        max_items_per_metre: The densest belt accepted (`MAX_ITEMS_PER_METRE` for one
            robot's pool, `LINE_MAX_ITEMS_PER_METRE` for a line's).
        held_shares: Material shares (n) the flow's items are held to, each within
            `sim.flow.mix.held_items(n_items)` items (a mix given as shares: the stripes' chains
            drawn again until their items carry it); None: the chains' draw as it falls.
        type_weights: Per catalogue item type, its weight within its material (shape variants
            0; a base type of weight 0 is not drawn); None: the catalogue's `weight`s.
        belt_width_m: The belt's width [m] (`BELT_WIDTH_RANGE_M`): the five stripes share it.
        rate_profile: The infeed's rate over time (`sim.flow.rate_profile`): items arrive at
            the base rate n_items / duration_s times its factor, `item_count` of them; empty:
            the base rate throughout.
    """

    n_items: int = 100
    duration_s: float = 90.0
    speed_factor: float = 1.0
    stripe_priors: tuple[float, ...] = DEFAULT_STRIPE_PRIORS
    transitions: tuple[tuple[float, ...], ...] | None = None
    class_priors: tuple[float, ...] | None = None
    seed: int = 0
    observation_period_s: float = OBSERVATION_PERIOD_S
    world: WorldVariation = field(default_factory=WorldVariation)
    n_materials: int = 3
    max_items_per_metre: float = MAX_ITEMS_PER_METRE
    type_weights: tuple[float, ...] | None = None
    held_shares: tuple[float, ...] | None = None
    belt_width_m: float = BELT_WIDTH_M
    rate_profile: RateProfile = field(default_factory=RateProfile)

    def __post_init__(self):
        n = self.n_items
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or not 1 <= n <= 100_000:
            raise InvalidInput("n_items", "an integer 1..100000", n)
        if not 1.0 <= float(self.duration_s) <= 1e6:
            raise InvalidInput("duration_s", "1..1e6 s", self.duration_s)
        lo, hi = BELT_SPEED_RANGE_MPS
        speed = BELT_SPEED_X1_MPS * float(self.speed_factor)
        if not lo - 1e-9 <= speed <= hi + _SPEED_SLACK_MPS:
            allowed = (
                f"{lo / BELT_SPEED_X1_MPS:.3f}..1.5 (the conveyor's {lo}..{hi} m/s "
                f"at {BELT_SPEED_X1_MPS} m/s per x1)"
            )
            raise InvalidInput("speed_factor", allowed, self.speed_factor)
        m = self.n_materials
        if isinstance(m, bool) or not isinstance(m, int | np.integer) or not 1 <= m <= 8:
            raise InvalidInput("n_materials", "an integer 1..8", m)
        self._set_probabilities(m)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int | np.integer):
            raise InvalidInput("seed", "an integer >= 0", self.seed)
        if self.seed < 0:
            raise InvalidInput("seed", "an integer >= 0", self.seed)
        if not 0.05 <= float(self.observation_period_s) <= 5.0:
            raise InvalidInput("observation_period_s", "0.05..5 s", self.observation_period_s)
        weights = self.type_weights
        if weights is not None:
            array = np.asarray(weights, dtype=float)
            if array.ndim != 1 or not np.all(np.isfinite(array)) or np.any(array < 0):
                raise InvalidInput("type_weights", "one weight >= 0 per item type", weights)
            object.__setattr__(self, "type_weights", tuple(array.tolist()))
        if not isinstance(self.world, WorldVariation):
            raise InvalidInput("world", "a WorldVariation", type(self.world).__name__)
        self._check_belt_width()
        self._check_rate_profile()
        self._check_density()

    def _check_rate_profile(self) -> None:
        """A `RateProfile` that brings 1..100000 items over the flow's duration."""
        profile = self.rate_profile
        if not isinstance(profile, RateProfile):
            raise InvalidInput("rate_profile", "a RateProfile", type(profile).__name__)
        if not 1 <= self.item_count <= 100_000:
            allowed = (
                f"a profile that brings 1..100000 items in {self.duration_s:g} s "
                f"(n_items x its mean factor)"
            )
            raise InvalidInput("infeed.profile", allowed, profile.steps)

    def _check_density(self) -> None:
        """The flow's densest belt (at the profile's peak) within `max_items_per_metre`."""
        peak = self.rate_profile.peak
        density = self.items_per_metre * peak
        limit = float(self.max_items_per_metre)
        if density > limit * (1 + 1e-9):
            most = int(limit * self.duration_s * self.belt_speed_mps / peak + 1e-6)
            at_peak = f" at the infeed profile's peak x{peak:g}" if self.rate_profile.steps else ""
            allowed = (
                f"at most {limit:g} items per metre of belt{at_peak}: <= {most} items "
                f"in {self.duration_s:g} s at x{self.speed_factor:g} (longer flows carry more)"
            )
            raise InvalidInput("n_items", allowed, self.n_items)

    def _set_probabilities(self, m: int) -> None:
        """The stripes', transitions', first items' and held shares' probabilities checked and
        stored as plain tuples (e.g. from TOML lists), so configs hash and compare by value."""
        stripes = _probabilities("stripe_priors", self.stripe_priors, (N_STRIPES,))
        given_transitions = self.transitions
        transitions = _probabilities(
            "transitions",
            default_transitions(m) if given_transitions is None else given_transitions,
            (m, m),
        )
        given_priors = self.class_priors
        classes = _probabilities(
            "class_priors", default_class_priors(m) if given_priors is None else given_priors, (m,)
        )
        object.__setattr__(self, "stripe_priors", tuple(stripes.tolist()))
        object.__setattr__(self, "transitions", tuple(tuple(r) for r in transitions.tolist()))
        object.__setattr__(self, "class_priors", tuple(classes.tolist()))
        if self.held_shares is not None:
            held = _probabilities("held_shares", self.held_shares, (m,))
            object.__setattr__(self, "held_shares", tuple(held.tolist()))

    def _check_belt_width(self) -> None:
        """The belt's width in `BELT_WIDTH_RANGE_M`, stored as a float."""
        lo, hi = BELT_WIDTH_RANGE_M
        if not is_finite_in(self.belt_width_m, lo, hi):
            raise InvalidInput("belt_width_m", f"{lo}..{hi} m", self.belt_width_m)
        object.__setattr__(self, "belt_width_m", float(self.belt_width_m))

    @property
    def item_count(self) -> int:
        """Items the flow carries: n_items, or with a rate profile round(n_items x the
        profile's integral over the duration / duration_s)."""
        if not self.rate_profile.steps:
            return self.n_items
        duration = float(self.duration_s)
        return round(self.n_items * float(self.rate_profile.cumulative(duration)) / duration)

    @property
    def belt_speed_mps(self) -> float:
        """Belt speed v [m/s]."""
        return BELT_SPEED_X1_MPS * float(self.speed_factor)

    @property
    def belt_half_width_m(self) -> float:
        """Half the belt's width [m]: items lie within +- it of the centre line."""
        return stripe_geometry(self.belt_width_m)[0]

    @property
    def stripe_width_m(self) -> float:
        """Width of each of the five stripes [m]."""
        return stripe_geometry(self.belt_width_m)[1]

    @property
    def items_per_metre(self) -> float:
        """Mean number of items per metre of belt at the base rate (factor 1)."""
        return self.n_items / (float(self.duration_s) * self.belt_speed_mps)

    @property
    def row_pitch_m(self) -> float:
        """Belt travel per observation period, the grid's row pitch [m]."""
        return self.belt_speed_mps * float(self.observation_period_s)

    @property
    def infeed_to_camera_s(self) -> float:
        """Time from the infeed to the camera line [s]."""
        return (X_CAMERA - X_INFEED) / self.belt_speed_mps

    @property
    def residence_s(self) -> float:
        """Time an item spends on the belt from the infeed to the discharge end [s]."""
        return (X_DISCHARGE - X_INFEED) / self.belt_speed_mps


def thesis_duration_s(n_items: int) -> float:
    """Duration [s] of a thesis flow of `n_items`: ~90 s, longer past 150 items (1.67 items/s)."""
    return max(90.0, n_items / (150 / 90))
