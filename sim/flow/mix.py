"""The flow's class mix as shares: the per-stripe Markov chain matched to them.

A flow draws each stripe's classes from a Markov chain (`sim.flow.generator`, thesis 2.2.6:
`transitions`, P(next class | previous class) within a stripe). The shares of the materials on
the belt over a long flow are that chain's stationary distribution, not its first item's
`class_priors`: the default transitions give about 28 % paper, 37 % plastic and 35 % aluminium
(`stationary_shares`). A mix given as shares is met by changing the table, not the method:

- `matched_transitions(table, shares)` is the table whose stationary distribution is `shares`
  and whose joint distribution of two successive items of a stripe, J_ij = pi_i P_ij, is the
  nearest to the given table's (least relative entropy) among those whose marginals are both
  `shares`. It is found by Sinkhorn's matrix scaling: J = diag(a) P diag(c), the row factors `a`
  and column factors `c` fitted in turn until J's row and column sums are the shares; then
  P'_ij = J_ij / shares_i. Scaling rows and columns keeps every odds ratio
  P_ij P_kl / (P_il P_kj) of the table exactly: how much more often an item follows one of its
  own class than of another stays the table's (the clumping of one bin emptied at a time); the
  self-transitions (how long a clump lasts) grow for a class whose share grows and shrink for
  one whose share shrinks, as they must for its share to change.
- A flow carries the mix: its chains are drawn again (from a stream of their own, the flow's
  other draws untouched) until each material's share of its items is less than 2 points from
  the mix (`held_items`; one item in a short flow): the chains conditioned on carrying it. A
  600-item flow of the chains alone strays by 2.2-2.8 points (one standard deviation, its
  clumps); a plant that sets a mix means the run to carry it.
- Each stripe's first item is drawn from the shares too (`class_priors` = shares), so the chain
  starts stationary: every item of the flow is of class c with probability shares[c].

A share of 0 leaves that class out (its column zeroed; its row, never used, scaled the same
way). A table that cannot reach the shares (a class of positive share that no other class of
positive share leads to, or that leads nowhere among them) is refused in one line.

The mix of item types (`type_weights`): within a material the flow draws its base types by
their weights (the catalogue's `weight`, or the shares a config gives per type); a config's
shares per type give both the material shares (each material's sum) and the weights.

Pure functions of numbers and the catalogue; no simulation.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from sim.errors import InvalidInput

HELD_TOLERANCE = 0.02
"""How far a flow's share of a material may come to the mix given as shares: less than 2
points, or one item in a flow too short for that (`held_items`)."""
HELD_SHARES_STREAM = 7
"""The stream of the flow's seed its chains are drawn again from (`numpy` seed sequence)."""
HELD_SHARES_MAX_DRAWS = 10_000
"""Most draws of the chains before a mix is refused as out of a flow's reach."""


def held_items(n_items: int) -> int:
    """How many items each material's count in a flow of `n_items` may lie from the mix's:
    the most that keep its share less than 2 points away, at least one."""
    return max(math.ceil(HELD_TOLERANCE * int(n_items)) - 1, 1)


SINKHORN_TOLERANCE = 1e-13
"""Largest error of a row or column sum of the matched joint distribution (probability)."""
SINKHORN_MAX_ROUNDS = 100_000
"""Most scaling rounds before a table is refused as unable to reach the shares."""


def stationary_shares(transitions) -> np.ndarray:
    """The stationary distribution of a row-stochastic table (the long-run class shares of a
    stripe's chain).

    Args:
        transitions: n x n rows P(next class | previous class), each summing to 1.

    Returns:
        (n,) shares summing to 1 (for a reducible table, the one reached from equal shares).
    """
    p = np.asarray(transitions, dtype=float)
    n = len(p)
    # pi (P - I) = 0 with sum(pi) = 1, as a least-squares system (exact for an irreducible P).
    a = np.vstack([(p - np.eye(n)).T, np.ones((1, n))])
    b = np.zeros(n + 1)
    b[-1] = 1.0
    pi, *_ = np.linalg.lstsq(a, b, rcond=None)
    pi = np.clip(pi, 0.0, None)
    return pi / pi.sum()


def matched_transitions(
    transitions, shares, field: str = "flow.mix"
) -> tuple[tuple[float, ...], ...]:
    """The transition table nearest to `transitions` whose stationary distribution is `shares`
    (the module docstring's method).

    Args:
        transitions: n x n row-stochastic table P(next class | previous class).
        shares: (n,) the wanted long-run shares, each in [0, 1], summing to 1.
        field: The key a refusal names.

    Returns:
        The matched n x n table, rows summing to 1.

    Raises:
        InvalidInput: The table cannot reach the shares (named `field`).
    """
    table = tuple(tuple(float(x) for x in row) for row in transitions)
    return _matched(table, tuple(float(s) for s in shares), field)


@functools.lru_cache(maxsize=256)
def _matched(
    transitions: tuple[tuple[float, ...], ...], shares: tuple[float, ...], field: str
) -> tuple[tuple[float, ...], ...]:
    """`matched_transitions` of hashable arguments (cached: a sweep's configs repeat them)."""
    p = np.asarray(transitions, dtype=float)
    pi = np.asarray(shares, dtype=float)
    keep = pi > 0
    sub = p[np.ix_(keep, keep)]
    target = pi[keep]
    if np.any(sub.sum(axis=1) <= 0) or np.any(sub.sum(axis=0) <= 0):
        _refuse(field, shares)
    a = np.ones(len(target))
    c = np.ones(len(target))
    for _ in range(SINKHORN_MAX_ROUNDS):
        a = target / (sub @ c)
        c = target / (sub.T @ a)
        joint = a[:, None] * sub * c[None, :]
        if np.max(np.abs(joint.sum(axis=1) - target)) < SINKHORN_TOLERANCE:
            break
    else:
        _refuse(field, shares)
    out = np.zeros_like(p)
    out[np.ix_(keep, keep)] = joint / target[:, None]
    # A class left out is never reached; its row (still a distribution) follows the same
    # column factors.
    column = np.zeros(len(pi))
    column[keep] = c
    for i in np.flatnonzero(~keep):
        row = p[i] * column
        out[i] = row / row.sum() if row.sum() > 0 else pi
    out /= out.sum(axis=1, keepdims=True)
    return tuple(tuple(float(x) for x in row) for row in out)


def _refuse(field: str, shares) -> None:
    allowed = (
        "shares the transitions can reach (every class of positive share led to from, and "
        "leading to, the others of positive share)"
    )
    raise InvalidInput(field, allowed, [float(s) for s in shares])


def type_shares(catalogue, type_weights=None) -> np.ndarray:
    """The share of each item type within its material, as the flow draws them.

    Args:
        catalogue: The item catalogue (`sim.flow.catalogue.Catalogue`).
        type_weights: Per catalogue type, its weight (variants 0); None: the catalogue's own.

    Returns:
        (types,) shares summing to 1 within each material (0 for shape variants and for a
        material all of whose weights are 0).
    """
    weights = (
        np.array([0.0 if t.variant_of else t.weight for t in catalogue.types])
        if type_weights is None
        else np.asarray(type_weights, dtype=float)
    )
    out = np.zeros(len(catalogue.types))
    for name in catalogue.materials.names:
        group = np.array(catalogue.of_material(name))
        total = weights[group].sum()
        if total > 0:
            out[group] = weights[group] / total
    return out


def mean_item_mass_kg(catalogue, material_shares, type_weights=None) -> float:
    """The mean mass of an item of the flow [kg]: the catalogue's masses of its base types
    weighted by their shares within their material and the materials' shares (the world's
    size variation changes single items' masses around them; `sim.flow.world`).

    Args:
        catalogue: The item catalogue.
        material_shares: (materials,) each material's share of the items, in the catalogue's
            order.
        type_weights: Per catalogue type, its weight within its material; None: the
            catalogue's.

    Returns:
        The mean item mass [kg].
    """
    within = type_shares(catalogue, type_weights)
    by_material = dict(zip(catalogue.materials.names, material_shares, strict=True))
    return float(
        sum(
            by_material[t.material] * within[k] * t.mass
            for k, t in enumerate(catalogue.types)
            if within[k] > 0
        )
    )


def shares_of_types(catalogue, mix_types: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The material shares and per-type weights of a mix given per item type.

    Args:
        catalogue: The item catalogue.
        mix_types: {base item type name: its share of all items}; types not named are not
            drawn.

    Returns:
        ((materials,) each material's share: the sum of its types'; (types,) each type's
        weight: its share, 0 for a type not named and for the shape variants).
    """
    weights = np.zeros(len(catalogue.types))
    for name, share in mix_types.items():
        weights[catalogue.index(name)] = float(share)
    materials = np.array(
        [weights[list(catalogue.of_material(m))].sum() for m in catalogue.materials.names]
    )
    return materials, weights
