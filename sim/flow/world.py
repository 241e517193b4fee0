"""How much the world varies: item sizes, shape variants, colours, labels, gaps and overlaps.

A real belt never carries two identical cans: sizes spread, some cans and bottles arrive
crushed, some sheets crumpled or folded, colours fade and shift, labels print a second colour on
most containers, and items fall touching or partly on top of flat ones. `WorldVariation` holds
these settings (docs/world.md gives the defaults' reasons); `draw_variation` draws every item's
share of them from its own random stream (`variation_rng`), so the flow's base draws (times,
stripes, classes, types, colours, places) are those of the uniform world, draw for draw.
`WorldVariation.uniform()` is the world before this module: every item its type's nominal size
and colour, 5 mm apart.
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass
from typing import cast

import numpy as np

from perception.codes import COLOURS
from sim.checks import check, is_finite_in
from sim.errors import InvalidInput
from sim.flow.catalogue import Catalogue
from sim.flow.limits import WORLD_LIMITS

LABEL_COLOURS = ("white", "blue", "red", "green")
"""Colours a printed label may have (opaque inks; never the item's own nominal colour)."""
UNIFORM_GAP_M = 0.005
"""The uniform world's clearance between items [m]."""


def _share(field: str, value: object, high: float = 1.0) -> float:
    check(is_finite_in(value, 0.0, high), field, f"a number in [0, {high:g}]", value)
    return float(cast(float, value))


@dataclass(frozen=True)
class WorldVariation:
    """How items vary from their catalogue type; the defaults are the varied world.

    Attributes:
        size_jitter: Half-range of the uniform size factors: length and width drawn
            independently in [1 - j, 1 + j], height too except for sheets (0..0.3).
        crushed_share: Share of the items of a type with a crushed variant (cans, bottles)
            that arrive crushed (0..1).
        crumpled_share: Share of the paper items with a crumpled variant drawn crumpled.
        folded_share: Share of the A4 sheets drawn folded (crumpled_share + folded_share <= 1).
        hue_jitter_deg: Half-range of the uniform hue shift of an item's colour [deg] (0..30).
        colour_jitter: Half-range of the relative saturation and value (brightness) change of
            an item's colour (0..0.5); alpha is kept, so transparent items stay transparent.
        label_share: Share of the round containers (cans, bottles, pots) carrying a printed
            label in a second colour (0..1).
        min_gap_m: Least gap between two items' footprints when generated [m] (0..0.05); 0:
            items may touch.
        overlap_share: Share of the items with flat sides lying down (boxes and sheets; a
            standing item would topple, a round one roll off) allowed to lie partly over a flat
            neighbour (a sheet, cardboard, a crushed box) dropped before them (0..1).
        overlap_depth_m: How far such an item may reach over its neighbour [m] (0..0.05).
    """

    size_jitter: float = 0.15
    crushed_share: float = 0.25
    crumpled_share: float = 0.2
    folded_share: float = 0.15
    hue_jitter_deg: float = 8.0
    colour_jitter: float = 0.12
    label_share: float = 0.6
    min_gap_m: float = 0.0
    overlap_share: float = 0.1
    overlap_depth_m: float = 0.02

    def __post_init__(self):
        for name, high in WORLD_LIMITS.items():
            object.__setattr__(self, name, _share(name, getattr(self, name), high))
        if self.crumpled_share + self.folded_share > 1.0 + 1e-12:
            allowed = "crumpled_share + folded_share <= 1"
            raise InvalidInput("folded_share", allowed, self.folded_share)

    @classmethod
    def uniform(cls) -> WorldVariation:
        """Today's uniform world: nominal sizes and colours, no variants, 5 mm apart."""
        return cls(
            size_jitter=0.0,
            crushed_share=0.0,
            crumpled_share=0.0,
            folded_share=0.0,
            hue_jitter_deg=0.0,
            colour_jitter=0.0,
            label_share=0.0,
            min_gap_m=UNIFORM_GAP_M,
            overlap_share=0.0,
            overlap_depth_m=0.0,
        )


def check_varied(world: WorldVariation, catalogue: Catalogue) -> None:
    """Refuse a catalogue whose items leave its limits once `world` varies their sizes (and
    with them their masses): the largest and the smallest item of each type (every size factor
    at 1 + j, every one at 1 - j) must be items the catalogue would take.

    Args:
        world: The variation's settings.
        catalogue: The item catalogue.

    Raises:
        InvalidInput: One line naming the key (`size`, `mass`) and the item (`where`), what the
            limit is once varied, and the catalogue's own (nominal) value.
    """
    j = world.size_jitter
    if j == 0.0:
        return
    for item_type in catalogue.types:
        for factor in (1.0 - j, 1.0 + j):
            try:
                item_type.scaled((factor,) * 3)
            except InvalidInput as exc:
                varied = f" once varied by size_jitter {j:g} (x{1 - j:g}..{1 + j:g})"
                nominal = getattr(item_type, exc.field, exc.got)
                where = f"item {item_type.name!r}"
                raise InvalidInput(exc.field, exc.allowed + varied, nominal, where) from None


@dataclass(frozen=True, eq=False)
class ItemVariation:
    """Per-item variation drawn for a flow (arrays in the flow's draw order).

    Attributes:
        variant: Catalogue index of the type actually on the belt (the base type or a variant).
        scale: (n, 3) effective size factors (length, width, height).
        rgba: (n, 4) the item's colour.
        label_rgba: (n, 4) its label's colour; alpha 0 when it has none.
        overlap: (n,) whether the item may lie partly over a flat neighbour.
    """

    variant: np.ndarray
    scale: np.ndarray
    rgba: np.ndarray
    label_rgba: np.ndarray
    overlap: np.ndarray


def variation_rng(seed: int) -> np.random.Generator:
    """The world variation's own random stream of a flow seed (apart from the base draws)."""
    return np.random.default_rng([int(seed), 1])


def jitter_rgba(rgba, u: np.ndarray, hue_deg: float, jitter: float) -> np.ndarray:
    """`rgba` with hue, saturation and value shifted by uniforms `u` (3,) in [-1, 1]."""
    r, g, b, a = (float(v) for v in rgba)
    if hue_deg == 0.0 and jitter == 0.0:
        return np.array([r, g, b, a])
    h, s, v = colorsys.rgb_to_hsv(r, g, b)
    h = (h + u[0] * hue_deg / 360.0) % 1.0
    s = min(max(s * (1.0 + u[1] * jitter), 0.0), 1.0)
    v = min(max(v * (1.0 + u[2] * jitter), 0.0), 1.0)
    return np.array([*colorsys.hsv_to_rgb(h, s, v), a])


def draw_variation(
    world: WorldVariation,
    catalogue: Catalogue,
    type_index: np.ndarray,
    colour: np.ndarray,
    rng: np.random.Generator,
) -> ItemVariation:
    """Every item's variant, size factors, colours and overlap permission.

    Args:
        world: The variation's settings.
        catalogue: Item types and colour table.
        type_index: (n,) base type of each item.
        colour: (n,) nominal colour index of each item.
        rng: The variation's random stream (`variation_rng`).
    """
    n = len(type_index)
    # Every draw is made for every item, whatever the settings, so one setting's change does
    # not shift the others' draws.
    u_variant = rng.random(n)
    u_scale = rng.uniform(-1.0, 1.0, size=(n, 3))
    u_colour = rng.uniform(-1.0, 1.0, size=(n, 3))
    u_label = rng.random(n)
    label_pick = rng.random(n)
    u_label_colour = rng.uniform(-1.0, 1.0, size=(n, 3))
    u_overlap = rng.random(n)

    crushed, crumpled = catalogue.variants("crushed"), catalogue.variants("crumpled")
    folded = catalogue.variants("folded")
    variant = np.asarray(type_index, dtype=np.int64).copy()
    k = variant
    c, f = world.crumpled_share, world.folded_share
    pick_crushed = (crushed[k] >= 0) & (u_variant < world.crushed_share)
    pick_crumpled = (crumpled[k] >= 0) & (u_variant < c)
    pick_folded = (folded[k] >= 0) & (u_variant >= c) & (u_variant < c + f)
    variant = np.where(pick_crushed, crushed[k], variant)
    variant = np.where(pick_crumpled, crumpled[k], variant)
    variant = np.where(pick_folded, folded[k], variant)

    factors = 1.0 + world.size_jitter * u_scale
    scale = np.array(
        [catalogue.types[v].effective_scale(f3) for v, f3 in zip(variant, factors, strict=True)]
    ).reshape(n, 3)

    rgba = np.empty((n, 4))
    label_rgba = np.zeros((n, 4))
    label_colours = [COLOURS.index(name) for name in LABEL_COLOURS]
    for i in range(n):
        rgba[i] = jitter_rgba(
            catalogue.rgba[int(colour[i])], u_colour[i], world.hue_jitter_deg, world.colour_jitter
        )
        item_type = catalogue.types[int(variant[i])]
        # Round containers (cans, bottles, pots) carry printed sleeves; boxes and sheets do not.
        if item_type.shape != "box" and u_label[i] < world.label_share:
            options = [x for x in label_colours if x != int(colour[i])]
            ink = options[min(int(label_pick[i] * len(options)), len(options) - 1)]
            label_rgba[i] = jitter_rgba(
                catalogue.rgba[ink], u_label_colour[i], world.hue_jitter_deg, world.colour_jitter
            )
            label_rgba[i, 3] = 1.0
    # Only items with flat sides lie partly over a neighbour: a standing one would topple, and a
    # round one lying (a bottle, a can) dropped with its flank over a neighbour's edge rolls
    # off it, upstream as fast as 0.34 m/s (seed 7103 of a line: two bottles and a can rolled
    # back past the infeed).
    lies_flat = np.array(
        [
            catalogue.types[v].pose != "standing" and catalogue.types[v].shape == "box"
            for v in variant
        ],
        dtype=bool,
    )
    overlap = (u_overlap < world.overlap_share) & lies_flat
    return ItemVariation(variant, scale, rgba, label_rgba, overlap)
