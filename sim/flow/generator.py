"""The material flow generator (thesis 2.2.6): which item falls where and when on the belt.

A biased random number generator, as in the thesis: items arrive one per time slot of
duration/n_items at a uniformly random instant within it (with an infeed rate profile,
`sim.flow.rate_profile`, the slots are the base clock's, mapped to real time before the items
are placed, so the gaps below hold in surges too); each falls in a stripe drawn from the
stripe priors; its class follows a Markov chain along the belt within that stripe (the first
item of a stripe from the class priors; a mix given as shares matches the chain to them,
`sim.flow.mix`); its type within the class follows the catalogue's weights (or the config's
`type_weights`) and its colour the type's colour distribution. The world's variation
(`sim.flow.world`, from its own random stream) then gives each item its shape variant (crushed,
crumpled, folded), size factors, colours and label, and whether it may lie partly over a flat
neighbour. The lateral position is uniform over the part of the stripe where the whole (scaled)
footprint stays on the belt, the yaw uniform (redrawn when the item would not fit). The stripes
share the belt's width (`FlowConfig.belt_width_m`); on a belt narrower than the thesis's an
item too wide for its outer stripe at every yaw tried lies along the belt as near that stripe
as its footprint allows, its centre in the next stripe (its class still drawn from its
stripe's chain). An item
that would come closer than the world's `min_gap_m` to one already on the belt is dropped later,
by just enough belt travel to clear it (and never before the previous item of its stripe), so
each stripe keeps its order; an item allowed to overlap may reach up to `overlap_depth_m` over a
flat item dropped before it, and is then dropped high enough to land on it.
Same config and seed, same flow, byte for byte; `WorldVariation.uniform()` gives the flows of
the uniform world (every item its type's nominal size and colour, 5 mm apart).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.errors import InvalidInput
from sim.flow.catalogue import Catalogue, ItemType
from sim.flow.config import (
    MAX_ITEMS_PER_METRE,
    N_STRIPES,
    STRIPE_WIDTH,
    X_DISCHARGE,
    X_INFEED,
    FlowConfig,
)
from sim.flow.footprint_polygons import polygon, shift_intervals
from sim.flow.mix import HELD_SHARES_MAX_DRAWS, HELD_SHARES_STREAM, held_items
from sim.flow.world import ItemVariation, draw_variation, variation_rng

EDGE_MARGIN_M = 0.005
YAW_TRIES = 8
# Most items on the belt at once at MAX_ITEMS_PER_METRE: 12/m x 4.25 m = 51 on average; the slot
# jitter and the shifts that keep items apart raise the peak: 36 flows of 1500 s at that density
# (x1, x1.2, x1.5, 12 seeds each) peaked at 64. Flows needing more are refused.
POOL_CAPACITY_REQUIRED = 72


@dataclass(frozen=True)
class Spawn:
    """One item of a flow: dropped at x = X_INFEED at `t` [s], at lateral `y` [m], `yaw` [rad]."""

    item_id: int
    t: float
    y: float
    yaw: float
    type_index: int
    class_id: int
    colour: int


@dataclass(frozen=True, eq=False)
class Flow:
    """A generated flow: one entry per item, in order of arrival at the infeed.

    Attributes:
        config: The settings it came from.
        t_spawn: Time the item is dropped at x = X_INFEED [s], non-decreasing.
        y: Lateral position of its centre [m].
        yaw: Heading of its body x axis [rad].
        type_index: Index into `Catalogue.types`.
        class_id: 2 paper, 3 plastic, 4 aluminium.
        colour: Index into `perception.codes.COLOURS`.
        stripe: Stripe 0..4 of its centre.
        variant: Index into `Catalogue.types` of the type actually dropped: `type_index` or one
            of its shape variants (crushed, crumpled, folded).
        scale: (n, 3) size factors (length, width, height) of the variant's nominal size.
        rgba: (n, 4) the item's own colour (its nominal colour `colour`, jittered).
        label_rgba: (n, 4) its printed label's colour; alpha 0 for none.
        z_drop: Height of what it lands on above the belt [m]: 0 on the belt, the top of the
            flat item it partly lies over otherwise.
    """

    config: FlowConfig
    t_spawn: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    type_index: np.ndarray
    class_id: np.ndarray
    colour: np.ndarray
    stripe: np.ndarray
    variant: np.ndarray
    scale: np.ndarray
    rgba: np.ndarray
    label_rgba: np.ndarray
    z_drop: np.ndarray

    def __len__(self) -> int:
        return len(self.t_spawn)

    def spawn(self, i: int) -> Spawn:
        return Spawn(
            i, float(self.t_spawn[i]), float(self.y[i]), float(self.yaw[i]),
            int(self.type_index[i]), int(self.class_id[i]), int(self.colour[i]),
        )  # fmt: skip

    def item_type(self, i: int, catalogue: Catalogue) -> ItemType:
        """The (scaled) item type of item `i` as dropped on the belt."""
        return catalogue.types[int(self.variant[i])].scaled(self.scale[i])

    def item_types(self, catalogue: Catalogue) -> tuple[ItemType, ...]:
        return tuple(self.item_type(i, catalogue) for i in range(len(self)))

    @property
    def item_id(self) -> np.ndarray:
        """Item ids 0..n-1 (arrival order)."""
        return np.arange(len(self))

    @property
    def tau(self) -> np.ndarray:
        """Time each item's centre crosses the camera line [s]."""
        return self.t_spawn + self.config.infeed_to_camera_s

    @property
    def row(self) -> np.ndarray:
        """Grid row of each item's centre (nearest to `tau`)."""
        return np.rint(self.tau / self.config.observation_period_s).astype(int)

    def x_at(self, t: float) -> np.ndarray:
        """Belt position x [m] of every item at time t [s] (NaN before its drop)."""
        x = X_INFEED + self.config.belt_speed_mps * (t - self.t_spawn)
        return np.where(t >= self.t_spawn, x, np.nan)

    def on_belt(self, t: float) -> np.ndarray:
        """Ids of the items between the infeed and the discharge end at time t [s]."""
        x = self.x_at(t)
        return np.flatnonzero((x >= X_INFEED) & (x < X_DISCHARGE))


def max_items_on_belt(flow: Flow) -> int:
    """Most items on the belt at once (none picked), infeed to discharge end."""
    t = flow.t_spawn
    if len(t) == 0:
        return 0
    first_on = np.searchsorted(t, t - flow.config.residence_s, side="right")
    return int((np.arange(len(t)) - first_on + 1).max())


def _draw_classes(config: FlowConfig, stripes: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Material index 0..n-1 of each item: a Markov chain per stripe, in arrival order."""
    assert config.class_priors is not None  # FlowConfig fills in the default
    prior_cdf = np.cumsum(config.class_priors)
    prior_cdf /= prior_cdf[-1]
    step_cdf = np.cumsum(np.asarray(config.transitions, dtype=float), axis=1)
    step_cdf /= step_cdf[:, -1:]
    out = np.empty(len(stripes), dtype=np.int64)
    top = len(prior_cdf) - 1
    last = [-1] * N_STRIPES
    for i, (stripe, draw) in enumerate(zip(stripes.tolist(), u.tolist(), strict=True)):
        cdf = prior_cdf if last[stripe] < 0 else step_cdf[last[stripe]]
        last[stripe] = out[i] = min(int(np.searchsorted(cdf, draw, side="right")), top)
    return out


def arrivals(config: FlowConfig, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """A flow's first draws, as `generate_flow` makes them from its generator: each item's
    time in its slot, its stripe and its material (the stripes' Markov chains), in slot order.

    Args:
        config: Flow settings.
        rng: `numpy.random.default_rng(config.seed)`, fresh.

    Returns:
        (t_slot [s], stripe 0..4, material index 0..n-1 in the catalogue's order), (n,) each.
    """
    n = config.item_count
    profile, duration = config.rate_profile, float(config.duration_s)
    slot = (float(profile.cumulative(duration)) if profile.steps else duration) / n
    t_slot = (np.arange(n) + rng.random(n)) * slot
    if profile.steps:  # the base clock's slot times in real time
        t_slot = profile.inverse(t_slot)
    stripes = rng.choice(N_STRIPES, size=n, p=np.asarray(config.stripe_priors, dtype=float))
    classes = _draw_classes(config, stripes, rng.random(n))
    if config.held_shares is not None:
        classes = held_to_shares(config, stripes, classes)
    return t_slot, stripes, classes


def held_to_shares(config: FlowConfig, stripes: np.ndarray, classes: np.ndarray) -> np.ndarray:
    """The stripes' chains drawn again, from a generator of their own seeded by the flow's
    seed, until each material's count of items is within `held_items(n)` of the count
    `config.held_shares` gives: the chains conditioned on carrying the mix (`sim.flow.mix`). The
    first draw is kept when it does; the flow's other draws are untouched either way."""
    n = len(classes)
    target = np.asarray(config.held_shares) * n
    allowed = held_items(n) + 1e-9
    redraws = np.random.default_rng([config.seed, HELD_SHARES_STREAM])
    for _ in range(HELD_SHARES_MAX_DRAWS):
        counts = np.bincount(classes, minlength=len(target))
        if np.all(np.abs(counts - target) <= allowed):
            return classes
        classes = _draw_classes(config, stripes, redraws.random(n))
    raise InvalidInput(
        "flow.mix", f"shares a flow of {n} items can carry within {held_items(n)} items",
        config.held_shares,
    )  # fmt: skip


def _type_weights(config: FlowConfig, catalogue: Catalogue, groups: list) -> list[np.ndarray]:
    """Each material's base types' weights (`groups`: their indices): the catalogue's, or
    the config's `type_weights`."""
    if config.type_weights is None:
        return [np.array([catalogue.types[i].weight for i in g]) for g in groups]
    if len(config.type_weights) != len(catalogue.types):
        allowed = f"one weight per item type of the catalogue ({len(catalogue.types)})"
        raise InvalidInput("type_weights", allowed, len(config.type_weights))
    given = np.asarray(config.type_weights)
    return [given[g] for g in groups]


def _draw_within(weights: list[np.ndarray], group: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Index drawn from weights[group[i]] with uniform u[i], for every i."""
    out = np.empty(len(group), dtype=np.int64)
    for g, w in enumerate(weights):
        mask = group == g
        if not mask.any():  # none drawn (a material of share 0 has no weight to divide by)
            continue
        cdf = np.cumsum(w) / np.sum(w)
        out[mask] = np.minimum(np.searchsorted(cdf, u[mask], side="right"), len(w) - 1)
    return out


def generate_flow(config: FlowConfig, catalogue: Catalogue, pool_size: int | None = None) -> Flow:
    """Generates the flow of `config` from `catalogue` (deterministic in `config.seed`).

    Args:
        pool_size: Item bodies the simulation has; a flow needing more at once on the belt is
            refused. Defaults to POOL_CAPACITY_REQUIRED.

    Raises:
        InvalidInput: An item type too wide for a stripe, or a flow the pool cannot hold.
    """
    pool_size = POOL_CAPACITY_REQUIRED if pool_size is None else pool_size
    materials = catalogue.materials
    if config.n_materials != materials.count:
        allowed = f"the catalogue's {materials.count} materials ({'/'.join(materials.names)})"
        raise InvalidInput("n_materials", allowed, config.n_materials)
    draws = _ItemDraws.drawn(config, catalogue)
    belt = _BeltPlacement(config, catalogue, draws)
    for i in range(config.item_count):
        belt.place(i)
    flow = belt.flow(materials.ids)
    most = max_items_on_belt(flow)
    if most > pool_size:
        allowed = (
            f"flows with at most {pool_size} items on the belt at once (this one has {most}; "
            f"at most {MAX_ITEMS_PER_METRE:g} items per metre of belt on average)"
        )
        raise InvalidInput("n_items", allowed, config.n_items)
    return flow


@dataclass(frozen=True, eq=False)
class _ItemDraws:
    """What the flow's random streams give each item, in slot order, before it is placed:
    its slot time [s], stripe, material index, base type and colour, the uniforms of its
    lateral place and yaws, and the world's variation (the scaled types dropped)."""

    t_slot: np.ndarray
    stripes: np.ndarray
    classes: np.ndarray
    type_index: np.ndarray
    colours: np.ndarray
    u_y: np.ndarray
    u_yaw: np.ndarray
    varied: ItemVariation
    types: list[ItemType]
    flat: np.ndarray

    @classmethod
    def drawn(cls, config: FlowConfig, catalogue: Catalogue) -> _ItemDraws:
        """The draws in the generator's fixed order (same seed, same draws)."""
        rng = np.random.default_rng(config.seed)
        n = config.item_count
        t_slot, stripes, classes = arrivals(config, rng)
        type_groups = [np.array(catalogue.of_material(m)) for m in catalogue.materials.names]
        type_weights = _type_weights(config, catalogue, type_groups)
        within = _draw_within(type_weights, classes, rng.random(n))
        type_index = np.array([type_groups[c][k] for c, k in zip(classes, within, strict=True)])
        colour_weights = [np.array(t.colour_probs) for t in catalogue.types]
        colours = _draw_within(colour_weights, type_index, rng.random(n))
        u_y = rng.random(n)
        u_yaw = rng.uniform(-math.pi, math.pi, size=(n, YAW_TRIES))
        varied = draw_variation(
            config.world, catalogue, type_index, colours, variation_rng(config.seed)
        )
        types = [
            catalogue.types[k].scaled(f) for k, f in zip(varied.variant, varied.scale, strict=True)
        ]
        flat = np.array([t.is_flat for t in types], dtype=bool)
        return cls(t_slot, stripes, classes, type_index, colours, u_y, u_yaw, varied, types, flat)


class _BeltPlacement:
    """The belt as the items are placed on it one by one, in slot order: each item's drop
    time [s], lateral place [m], yaw [rad] and landing height [m], and what its successors
    are kept clear of (footprints in the belt frame at time 0, reaches, lateral half-extents)."""

    def __init__(self, config: FlowConfig, catalogue: Catalogue, draws: _ItemDraws):
        n = config.item_count
        self.config = config
        self.draws = draws
        self.t_spawn = np.empty(n)
        self.y = np.empty(n)
        self.yaw = np.empty(n)
        self.z_drop = np.zeros(n)
        self.polygons = np.empty((n, 16, 2))
        self.reach = np.empty(n)
        self.half_y = np.empty(n)
        self.reach_max = max(
            math.hypot(t.half_length, t.half_width) for t in (*catalogue.types, *draws.types)
        )
        self.last_in_stripe = [0.0] * N_STRIPES
        self.latest = np.empty(n)

    def place(self, i: int) -> None:
        """Item `i` placed: its lateral place and yaw, then dropped late enough to keep clear
        of the items before it (and never before the previous item of its stripe)."""
        d, v = self.draws, self.config.belt_speed_mps
        item_type = d.types[i]
        stripe = d.stripes[i]
        self.y[i], self.yaw[i] = _lateral(item_type, int(stripe), d.u_y[i], d.u_yaw[i], self.config)
        t_i = max(float(d.t_slot[i]), self.last_in_stripe[stripe])
        shape = polygon(item_type, 0.0, self.y[i], self.yaw[i])
        self.reach[i] = math.hypot(item_type.half_length, item_type.half_width)
        self.half_y[i] = float(item_type.half_extents(self.yaw[i])[1])
        near = _neighbours(
            i, t_i, v, self.y[i], self.half_y, self.reach, self.reach_max, self.latest, self.y,
            self.config.world.min_gap_m,
        )  # fmt: skip
        if len(near):
            t_i = self._clear_of(i, near, t_i, shape)
        self.t_spawn[i] = self.last_in_stripe[stripe] = t_i
        self.latest[i] = t_i if i == 0 else max(t_i, self.latest[i - 1])
        self.polygons[i] = shape

    def _clear_of(self, i: int, near: np.ndarray, t_i: float, shape: np.ndarray) -> float:
        """The drop time of item `i` delayed by just enough belt travel to clear its `near`
        neighbours; an item allowed to overlap may lie partly over a flat one dropped before
        it, and then lands on it (its `z_drop` that item's top)."""
        v, world, types = self.config.belt_speed_mps, self.config.world, self.draws.types
        # Belt frame at time 0: an item dropped at t sits at x = -v t.
        offset = np.zeros((len(near), 1, 2))
        offset[:, 0, 0] = v * self.t_spawn[near]
        others = self.polygons[near] - offset
        clearance = np.full((len(near), 1), world.min_gap_m)
        base = np.zeros(len(near), dtype=bool)
        if self.draws.varied.overlap[i]:
            # Only over a flat item dropped before it (it lands on that one) and lying on
            # the belt itself, by at most a quarter of that item's width.
            base = self.draws.flat[near] & (self.t_spawn[near] <= t_i) & (self.z_drop[near] == 0.0)
            widths = np.array([types[j].half_width for j in near])
            depth = np.minimum(world.overlap_depth_m, 0.5 * widths)
            clearance[base, 0] = -depth[base]
        lo, hi = shift_intervals(shape - [v * t_i, 0.0], others, clearance)
        delta = 0.0
        for a, b in sorted(zip(lo[lo < hi].tolist(), hi[lo < hi].tolist(), strict=True)):
            if a < delta < b:
                delta = b
        t_i += delta / v
        if base.any():
            lo, hi = shift_intervals(shape - [v * t_i, 0.0], others[base], 0.0)
            under = near[base][(lo < 0.0) & (0.0 < hi)]
            if len(under):
                self.z_drop[i] = max(2.0 * types[j].rest_height for j in under)
        return t_i

    def flow(self, material_ids) -> Flow:
        """The placed items as a flow, in order of arrival at the infeed."""
        d = self.draws
        order = np.argsort(self.t_spawn, kind="stable")
        return Flow(
            config=self.config,
            t_spawn=self.t_spawn[order],
            y=self.y[order],
            yaw=self.yaw[order],
            type_index=d.type_index[order].astype(np.int64),
            class_id=np.asarray(material_ids)[d.classes[order]],
            colour=d.colours[order].astype(np.int64),
            stripe=d.stripes[order].astype(np.int64),
            variant=d.varied.variant[order].astype(np.int64),
            scale=d.varied.scale[order],
            rgba=d.varied.rgba[order],
            label_rgba=d.varied.label_rgba[order],
            z_drop=self.z_drop[order],
        )


def _lateral(
    item_type, stripe: int, u_y: float, u_yaw: np.ndarray, config: FlowConfig
) -> tuple[float, float]:
    """(y, yaw) of an item in `stripe` whose footprint stays on the belt."""
    half_belt, width = config.belt_half_width_m, config.stripe_width_m
    lo_stripe = -half_belt + width * stripe
    hi_stripe = lo_stripe + width
    # Tries the drawn yaws in turn; an item too wide at all of them lies along the belt.
    along = 0.0 if item_type.half_width <= item_type.half_length else 1.5708
    for yaw in [*u_yaw.tolist(), along]:
        half_y = float(item_type.half_extents(yaw)[1])
        lo = max(lo_stripe, -half_belt + half_y + EDGE_MARGIN_M)
        hi = min(hi_stripe, half_belt - half_y - EDGE_MARGIN_M)
        if lo < hi:
            return lo + u_y * (hi - lo), yaw
    # A belt narrower than the thesis's: the footprint on the belt, as near the stripe as it can.
    edge = half_belt - float(item_type.half_extents(along)[1]) - EDGE_MARGIN_M
    if width < STRIPE_WIDTH and edge > 0.0:
        return min(max(0.5 * (lo_stripe + hi_stripe), -edge), edge), along
    raise InvalidInput("size", "footprints that fit the outer stripes", item_type.name)


def _neighbours(i, t_i, v, y_i, half_y, reach, reach_max, latest, y, gap) -> np.ndarray:
    """Items placed before item i that it could touch, now or once dropped later.

    `latest[j]` is the latest drop time among items 0..j (non-decreasing), so items before the
    first j with latest[j] >= t_i - window are all too far downstream.
    """
    window = (reach[i] + reach_max + gap) / v
    start = int(np.searchsorted(latest[:i], t_i - window, side="left"))
    near = np.arange(start, i)
    if len(near) == 0:
        return near
    apart = np.abs(y[near] - y_i) > half_y[near] + half_y[i] + gap
    return near[~apart]
