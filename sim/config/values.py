"""The `[values]` table: what an item is worth, per item or per kilogram, by material or item
type of the catalogue."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from perception.codes import Materials
from sim.checks import check
from sim.config.fields import SETTING, Range, setting
from sim.errors import InvalidInput
from sim.flow.catalogue import Catalogue

MAX_VALUE_EUR = 1e6
"""Highest value of an item [EUR]."""


@dataclass(frozen=True)
class Values:
    """Value of an item [EUR]: per item of a material (thesis table 3.3 by default) or of one
    item type of the catalogue (which overrides its material's value in the profit), or per
    kilogram (`per_kg`, a table of EUR/kg by material or item type: an item is then worth its
    own mass, as varied, times that price). A name has one or the other, not both. An item is
    worth, in this order: its type's value per item, its type's per kg, its material's per kg,
    its material's per item. Names not set take the catalogue's `value_eur` of their
    material. The decision managers weigh a material valued per kg by its mean item: the price
    times the catalogue's mean mass of its item types (their `weight`s; `mean_masses`).

    Attributes:
        eur: (name, EUR per item) pairs as the `[values]` table gives them.
        per_kg: (name, EUR per kg) pairs of its `per_kg` table [EUR/kg].
    """

    eur: tuple[tuple[str, float], ...] = setting(
        (), range=Range(0.0, MAX_VALUE_EUR, f"0..{MAX_VALUE_EUR:g} EUR"), name="<material>"
    )
    per_kg: tuple[tuple[str, float], ...] = setting(
        (),
        range=Range(0.0, MAX_VALUE_EUR, f"0..{MAX_VALUE_EUR:g} EUR/kg"),
        name="per_kg.<material>",
    )

    def __post_init__(self) -> None:
        pairs = tuple((k, v) for k, v in self.eur)
        for name, got in pairs:
            _range("eur").check(f"values.{name}", got)
        per_kg = tuple((k, v) for k, v in self.per_kg)
        for name, got in per_kg:
            _range("per_kg").check(f"values.per_kg.{name}", got)
        both = [name for name, _ in per_kg if name in dict(pairs)]
        if both:
            allowed = f"a value per item or per kg (values.per_kg.{both[0]}), not both"
            raise InvalidInput(f"values.{both[0]}", allowed, dict(pairs)[both[0]])
        object.__setattr__(self, "eur", pairs)
        object.__setattr__(self, "per_kg", per_kg)

    @classmethod
    def from_table(cls, table: dict[str, Any]) -> Values:
        """The `[values]` table as parsed: {name: EUR}, and `per_kg`: {name: EUR/kg}."""
        per_kg = table.get("per_kg", {})
        allowed = "a table of EUR per kg by material or item type"
        check(isinstance(per_kg, dict), "values.per_kg", allowed, per_kg, None)
        eur = tuple((k, v) for k, v in table.items() if k != "per_kg")
        return cls(eur, tuple(per_kg.items()))

    def given(self) -> dict[str, float]:
        """{material or item type name: EUR per item} as set."""
        return {k: float(v) for k, v in self.eur}

    def given_per_kg(self) -> dict[str, float]:
        """{material or item type name: EUR/kg} as set."""
        return {k: float(v) for k, v in self.per_kg}

    def of_materials(self, materials: Materials) -> tuple[float, ...]:
        """Each material's value per item [EUR], the catalogue's where not set, in the
        materials' order (the decision managers')."""
        given = self.given()
        return tuple(
            given.get(n, d) for n, d in zip(materials.names, materials.values_eur, strict=True)
        )

    def for_planning(self, catalogue: Catalogue) -> tuple[float, ...]:
        """Each material's value per item [EUR] as the decision managers weigh it: a material
        priced per kg at its mean item's mass (`mean_masses`), the others as `of_materials`."""
        per_kg = self.given_per_kg()
        if not per_kg:
            return self.of_materials(catalogue.materials)
        masses = mean_masses(catalogue)
        return tuple(
            per_kg[n] * masses[n] if n in per_kg else v
            for n, v in zip(
                catalogue.materials.names, self.of_materials(catalogue.materials), strict=True
            )
        )

    def by_class(self, materials: Materials) -> dict[int, float]:
        """{material class id (2, 3, ...): EUR per item}."""
        return dict(zip(materials.ids, self.of_materials(materials), strict=True))

    def of_types(self, catalogue: Catalogue) -> dict[int, float]:
        """{catalogue type index: EUR} of the item types given a value per item of their own
        (their shape variants, a crushed can of a can type, take it too)."""
        given = self.given()
        out = {}
        for k, t in enumerate(catalogue.types):
            base = t.variant_of or t.name
            if base in given:
                out[k] = given[base]
        return out

    def of_items(self, catalogue: Catalogue, types, masses) -> dict[int, float]:
        """{item id: EUR} of the items not worth their material's value per item: their
        type's own value per item, else their mass as varied [kg] (`masses`, by item id) times
        their type's or material's price per kg; `types`: each item's base type index
        (`Flow.type_index`)."""
        by_type = self.of_types(catalogue)
        per_kg = self.given_per_kg()
        out = {}
        for i, (k, mass) in enumerate(zip(types, masses, strict=True)):
            t = catalogue.types[int(k)]
            if int(k) in by_type:
                out[i] = by_type[int(k)]
            elif (t.variant_of or t.name) in per_kg:
                out[i] = per_kg[t.variant_of or t.name] * float(mass)
            elif t.material in per_kg:
                out[i] = per_kg[t.material] * float(mass)
        return out

    def check_names(self, catalogue: Catalogue, where: str | None) -> None:
        """Refuse a name that is neither a material nor a base item type of `catalogue`,
        naming the config file `where`."""
        names = set(catalogue.materials.names)
        names |= {t.name for t in catalogue.types if not t.variant_of}
        allowed = "a material (" + ", ".join(catalogue.materials.names) + ") or item type"
        for name, _ in self.eur:
            check(name in names, f"values.{name}", allowed, None, where)
        for name, _ in self.per_kg:
            check(name in names, f"values.per_kg.{name}", allowed, None, where)

    def table(self, materials: Materials) -> dict[str, Any]:
        """The resolved `[values]` table: {name: EUR}, every material's value per item (but
        those priced per kg), then the item types' given; `per_kg` {name: EUR/kg} when set."""
        per_kg = self.given_per_kg()
        out: dict[str, Any] = {
            n: v
            for n, v in zip(materials.names, self.of_materials(materials), strict=True)
            if n not in per_kg
        }
        out.update({k: v for k, v in self.given().items() if k not in out})
        if per_kg:
            out["per_kg"] = per_kg
        return out


def _range(name: str) -> Range:
    """The range of a `Values` field's every entry."""
    return Values.__dataclass_fields__[name].metadata[SETTING].range


def mean_masses(catalogue: Catalogue) -> dict[str, float]:
    """{material name: its mean item mass [kg]} by the catalogue's weights of its base types
    (nominal sizes)."""
    out = {}
    for name in catalogue.materials.names:
        types = [catalogue.types[k] for k in catalogue.of_material(name)]
        total = sum(t.weight for t in types)
        out[name] = sum(t.weight * t.mass for t in types) / total
    return out
