"""The infeed's rate over time: a step profile of factors on the flow's base arrival rate.

A profile is a list of steps (start_s, factor): from each start on [s] the items arrive at the
flow's base rate (n_items / duration_s) times the factor, until the next step. Before the first
step the factor is 1; a factor of 0 is a gap in the feed (a tipping floor empty), a factor above
1 a surge. The flow draws its items' slot times on the base clock, whose time runs at the
factor's pace, and maps them to real time by `inverse`: the items of a surge come closer
together, none come in a gap.

`draw_surges` draws surges of one factor with exponential gaps and lengths from the seed's own
random stream (the flow's other draws are unchanged); `combined` multiplies two profiles (a
given profile and the drawn surges). Pure functions of numbers; nothing heavy is imported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sim.checks import check, is_finite_in, is_finite_number, is_integer

SURGE_STREAM = 49
"""The surges' own stream of a flow seed (`numpy.random.default_rng([seed, SURGE_STREAM])`)."""
MEAN_S_RANGE = (1.0, 1e6)
"""A surge's mean gap and mean length [s]."""


def _valid_steps(steps: object) -> bool:
    try:
        pairs = [tuple(step) for step in steps]  # type: ignore[attr-defined]
    except TypeError:
        return False
    if not all(len(p) == 2 and all(is_finite_number(v) for v in p) for p in pairs):
        return False
    starts = [p[0] for p in pairs]
    return (
        all(p[1] >= 0 for p in pairs)
        and all(s >= 0 for s in starts[:1])
        and all(a < b for a, b in zip(starts, starts[1:], strict=False))
    )


@dataclass(frozen=True)
class RateProfile:
    """The infeed's rate factor over time, validated on construction.

    Attributes:
        steps: ((start_s, factor), ...): starts [s] >= 0 and strictly ascending, factors >= 0
            and finite; the factor is 1 before the first start. Empty: 1 throughout.
    """

    steps: tuple[tuple[float, float], ...] = ()
    _starts: np.ndarray = field(init=False, repr=False, compare=False)
    _factors: np.ndarray = field(init=False, repr=False, compare=False)
    _at_starts: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        allowed = "[[start_s, factor], ...]: starts >= 0 s and ascending, factors >= 0, finite"
        check(_valid_steps(self.steps), "infeed.profile", allowed, self.steps)
        steps = tuple((float(s), float(f)) for s, f in self.steps)
        object.__setattr__(self, "steps", steps)
        # Segments from 0 on: starts, factors and the cumulative at each start.
        starts = [s for s, _ in steps]
        factors = [f for _, f in steps]
        if not steps or starts[0] > 0.0:
            starts, factors = [0.0, *starts], [1.0, *factors]
        at = np.array(starts)
        reached = np.concatenate(([0.0], np.cumsum(np.diff(at) * factors[:-1])))
        object.__setattr__(self, "_starts", at)
        object.__setattr__(self, "_factors", np.array(factors))
        object.__setattr__(self, "_at_starts", reached)

    @property
    def peak(self) -> float:
        """The highest factor, 1 before the first step included."""
        return float(self._factors.max())

    def factor_at(self, t):
        """The factor at time(s) `t` [s] (>= 0)."""
        index = np.searchsorted(self._starts, t, side="right") - 1
        return self._factors[np.maximum(index, 0)]

    def cumulative(self, t):
        """Integral of the factor over [0, t] [s] (the base clock's time at real time t)."""
        index = np.maximum(np.searchsorted(self._starts, t, side="right") - 1, 0)
        return self._at_starts[index] + (t - self._starts[index]) * self._factors[index]

    def inverse(self, tau):
        """The real time(s) [s] at which `cumulative` reaches `tau` [s]: within a gap (factor 0)
        the latest, its end; inf for tau at or past the level of a gap that never ends."""
        index = np.searchsorted(self._at_starts, tau, side="right") - 1
        index = np.maximum(index, 0)
        factor = self._factors[index]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = self._starts[index] + (tau - self._at_starts[index]) / factor
        return np.where(factor > 0, t, math.inf)

    def combined(self, other: RateProfile) -> RateProfile:
        """The profile whose factor is this one's times `other`'s at every time."""
        if not other.steps:
            return self
        if not self.steps:
            return other
        starts = sorted({s for s, _ in self.steps} | {s for s, _ in other.steps})
        factors = np.asarray(self.factor_at(starts)) * np.asarray(other.factor_at(starts))
        return RateProfile(tuple(zip(starts, factors.tolist(), strict=True)))


def draw_surges(
    seed: int, mean_gap_s: float, mean_length_s: float, factor: float, end_s: float
) -> RateProfile:
    """Surges of `factor` over [0, end_s) [s]: from 0 on, a gap and then a surge, their lengths
    [s] exponential of means `mean_gap_s` and `mean_length_s`, drawn in turn from the seed's own
    stream (same arguments, same surges); the factor is 1 between surges."""
    lo, hi = MEAN_S_RANGE
    check(is_integer(seed) and seed >= 0, "seed", "an integer >= 0", seed)
    for key, value in (("mean_gap_s", mean_gap_s), ("mean_length_s", mean_length_s)):
        check(is_finite_in(value, lo, hi), f"infeed.surges.{key}", f"{lo:g}..{hi:g} s", value)
    check(is_finite_in(factor, 0.0, math.inf), "infeed.surges.factor", "a number >= 0", factor)
    check(is_finite_in(end_s, 0.0, math.inf), "end_s", "a number of s >= 0", end_s)
    rng = np.random.default_rng([int(seed), SURGE_STREAM])
    steps: list[tuple[float, float]] = []
    t = float(rng.exponential(mean_gap_s))
    while t < end_s:
        length = float(rng.exponential(mean_length_s))
        _step(steps, t, float(factor))
        _step(steps, t + length, 1.0)
        t += length + float(rng.exponential(mean_gap_s))
    return RateProfile(tuple(steps))


def _step(steps: list[tuple[float, float]], start: float, factor: float) -> None:
    """`steps` with (start, factor) added; a start no later than the last one's (a gap or a
    surge drawn shorter than the time's resolution) replaces that step."""
    if steps and start <= steps[-1][0]:
        steps[-1] = (steps[-1][0], factor)
    else:
        steps.append((start, factor))
