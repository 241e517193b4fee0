"""The `[flow]` table: the flow's class mix, as the thesis's probabilities or as shares by
material or item type (`sim.flow.mix` matches the transitions to them)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from sim.checks import check, is_number
from sim.config.fields import Range, setting
from sim.flow import mix as flow_mix
from sim.flow.catalogue import Catalogue
from sim.flow.config import default_transitions

if TYPE_CHECKING:
    import numpy as np

_PROBABILITIES = "probabilities, each in [0, 1], summing to 1"
_SHARES = Range(0.0, 1.0, "shares in [0, 1] summing to 1", entries="table")


def _probabilities(entries: str) -> Range:
    """A list (or rows) of probabilities, checked by `sim.flow.config.FlowConfig`."""
    return Range(0.0, 1.0, _PROBABILITIES, entries=entries, checked_by="sim.flow")


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

    class_priors: tuple[float, ...] | None = setting(range=_probabilities("list"))
    transitions: tuple[tuple[float, ...], ...] | None = setting(range=_probabilities("rows"))
    stripe_priors: tuple[float, ...] | None = setting(range=_probabilities("list"))
    mix: tuple[tuple[str, float], ...] | None = setting(range=_SHARES)
    mix_types: tuple[tuple[str, float], ...] | None = setting(range=_SHARES)

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
        r = _SHARES
        fine = all(r.allows(x) for x in shares.values()) and abs(sum(shares.values()) - 1) <= 1e-6
        check(fine, f"flow.{name}", r.allowed, shares, None)
        object.__setattr__(self, name, tuple((k, float(x)) for k, x in v))

    def check_names(self, catalogue: Catalogue, where: str | None) -> None:
        """Refuse a `mix` that does not name every material of `catalogue` (and nothing else),
        a `mix_types` naming anything but its base item types (naming the file `where`)."""
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
        assert catalogue is not None, "flow.mix and flow.mix_types need the catalogue"
        materials = catalogue.materials
        shares: list[float] | np.ndarray
        if self.mix is not None:
            shares = [dict(self.mix)[n] for n in materials.names]
        else:
            assert self.mix_types is not None
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


def _plain(value: Any) -> Any:
    """Tuples as lists (TOML's and JSON's arrays), nested."""
    return [_plain(v) for v in value] if isinstance(value, tuple | list) else value
