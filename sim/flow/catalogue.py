"""The item catalogue (`sim/data/items.toml`): item types, MuJoCo shapes, masses, colours.

Body frame convention shared by the flow, the ground truth and the cell's item bodies: z up, the
item's long axis along the body's x axis, origin at the item's centre, which rests `rest_height`
above the belt. A lying cylinder or capsule therefore has its geom rotated by `geom_quat` (the
geom's own z axis onto the body's x axis). The footprint on the belt is a rectangle (box, lying
cylinder), a disc (standing cylinder) or a stadium (lying capsule) in the body's xy plane.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from perception.codes import COLOURS, THESIS_MATERIALS, Materials
from sim.checks import is_finite_number
from sim.errors import InvalidInput
from sim.flow.limits import MASS_RANGE_KG
from sim.paths import DATA_DIR

MATERIALS = THESIS_MATERIALS.names
"""The default catalogue's materials (the thesis's); a catalogue may name its own."""
SHAPE_POSES = {"box": ("flat",), "cylinder": ("standing", "lying"), "capsule": ("lying",)}
SIZE_LEN = {"box": 3, "cylinder": 2, "capsule": 2}
LYING_QUAT = (math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0)
VARIANT_KINDS = ("crushed", "crumpled", "folded")
SHEET_HALF_THICKNESS_M = 0.0025
"""Boxes at most this thick (half-size) are sheets: paper, cardboard [m]."""
FAMILIES = ("box", "cylinder_standing", "cylinder_lying", "capsule_lying")
"""Shape-and-pose families: one geom of each per item-pool slot."""
HALF_SIZE_RANGE_M = (0.001, 0.5)
"""An item's half-sizes (a cylinder's radius and half-height, ...) [m]: from 1 mm (a 2 mm sheet,
as thin as its contacts stay well conditioned at the 1 ms step) to 0.5 m."""
FRICTION_RANGES = ((0.05, 2.0), (0.0, 0.05), (0.0, 0.01))
"""MuJoCo's (sliding, torsional [m], rolling [m]) friction of an item on the belt. Sliding: 0
carries nothing (the items slide off the belt's end), and past about 3 the contact solver
throws items off the belt (1e9 throws every one); 0.05 and 2 carry and pick as 0.55 does (20
items, `tests/test_config_ranges.py`). Torsional and rolling: up to a contact patch's size."""


@dataclass(frozen=True)
class ItemType:
    """One kind of item.

    Attributes:
        name: Unique name, e.g. "pet_bottle_0l5".
        material: Its material: one of the catalogue's `[[material]]` names ("paper",
            "plastic" or "aluminium" in the default catalogue).
        shape: MuJoCo geom type: "box", "cylinder" or "capsule".
        pose: "flat", "standing" or "lying" (see the module docstring).
        size: MuJoCo geom size [m]: box half-sizes (3); cylinder (radius, half-height);
            capsule (radius, half-length of the straight part).
        mass: Mass [kg].
        friction: MuJoCo (sliding, torsional, rolling) friction.
        weight: Relative frequency within its material class.
        colour_probs: Probability of each colour of `perception.codes.COLOURS` (sums to 1).
        variant_of: For a shape variant (a crushed can, a crumpled sheet), the name of the
            base type it is drawn in place of; "" for a base type.
        kind: The variant's kind (`VARIANT_KINDS`); "" for a base type.
    """

    name: str
    material: str
    shape: str
    pose: str
    size: tuple[float, ...]
    mass: float
    friction: tuple[float, float, float]
    weight: float
    colour_probs: tuple[float, ...]
    variant_of: str = ""
    kind: str = ""
    class_id: int = 0
    """Class id of its material in its catalogue (2, 3, ...; set by `Catalogue`)."""

    def __post_init__(self):
        where = f"item {self.name!r}"
        if bool(self.variant_of) != bool(self.kind) or self.kind not in ("", *VARIANT_KINDS):
            raise InvalidInput(
                "kind", "/".join(VARIANT_KINDS) + " with variant_of", self.kind, where
            )
        if not isinstance(self.material, str) or not self.material:
            raise InvalidInput("material", "a material name", self.material, where)
        if self.shape not in SHAPE_POSES:
            raise InvalidInput("shape", "/".join(SHAPE_POSES), self.shape, where)
        if self.pose not in SHAPE_POSES[self.shape]:
            raise InvalidInput("pose", "/".join(SHAPE_POSES[self.shape]), self.pose, where)
        lo, hi = HALF_SIZE_RANGE_M
        if len(self.size) != SIZE_LEN[self.shape] or not all(lo <= s <= hi for s in self.size):
            allowed = f"{SIZE_LEN[self.shape]} half-sizes in {lo:g}..{hi:g} m for a {self.shape}"
            raise InvalidInput("size", allowed, self.size, where)
        lo, hi = MASS_RANGE_KG
        if not lo <= self.mass <= hi:
            allowed = f"{lo:g}..{hi:g} kg (MuJoCo's least mass and inertia; the robot's payload)"
            raise InvalidInput("mass", allowed, self.mass, where)
        ranges = FRICTION_RANGES
        ok = len(self.friction) == 3
        if not ok or not all(a <= f <= b for f, (a, b) in zip(self.friction, ranges, strict=True)):
            allowed = "sliding {:g}..{:g} (a belt carries it), torsional {:g}..{:g} m, rolling "
            allowed += "{:g}..{:g} m"
            allowed = allowed.format(*(x for r in ranges for x in r))
            raise InvalidInput("friction", allowed, self.friction, where)
        if not self.weight > 0:
            raise InvalidInput("weight", "> 0", self.weight, where)
        probs = self.colour_probs
        if len(probs) != len(COLOURS) or min(probs) < 0 or abs(sum(probs) - 1) > 1e-9:
            raise InvalidInput("colours", f"weights over {COLOURS} summing to 1", probs, where)

    @property
    def family(self) -> str:
        """Shape-and-pose family (`FAMILIES`), e.g. "cylinder_lying"."""
        return "box" if self.shape == "box" else f"{self.shape}_{self.pose}"

    @property
    def is_sheet(self) -> bool:
        """A box thin as a sheet (paper, cardboard): its thickness is not scaled."""
        return self.shape == "box" and self.size[2] <= SHEET_HALF_THICKNESS_M

    @property
    def is_flat(self) -> bool:
        """Flat enough for another item to lie partly on it: a sheet or a crushed box."""
        return self.is_sheet or (self.shape == "box" and self.kind == "crushed")

    def effective_scale(self, factors) -> tuple[float, float, float]:
        """The factors (length, width, height) this shape can take from drawn `factors`.

        A sheet keeps its thickness (height 1); a standing cylinder's disc scales with the
        length factor alone; a lying cylinder's or capsule's height is its width (the radius).
        """
        fx, fy, fz = (float(f) for f in factors)
        if self.shape == "box":
            return fx, fy, 1.0 if self.is_sheet else fz
        if self.pose == "standing":
            return fx, fx, fz
        return fx, fy, fy

    def scaled(self, factors) -> ItemType:
        """This type scaled by (length, width, height) `factors` (see `effective_scale`); the
        mass scales with the volume (with the area for sheets, whose thickness stays)."""
        fx, fy, fz = self.effective_scale(factors)
        if (fx, fy, fz) == (1.0, 1.0, 1.0):
            return self
        size: tuple[float, ...]
        if self.shape == "box":
            size = (self.size[0] * fx, self.size[1] * fy, self.size[2] * fz)
        elif self.pose == "standing":
            size = (self.size[0] * fx, self.size[1] * fz)
        else:
            size = (self.size[0] * fy, self.size[1] * fx)
        return dataclasses.replace(self, size=size, mass=self.mass * fx * fy * fz)

    @property
    def footprint(self) -> tuple[str, float, float]:
        """(kind, a, b) in the body frame: ("rect", hx, hy), ("disc", r, r), ("stadium", h, r)."""
        if self.shape == "box":
            return "rect", self.size[0], self.size[1]
        radius, half = self.size
        if self.pose == "standing":
            return "disc", radius, radius
        return ("rect" if self.shape == "cylinder" else "stadium"), half, radius

    @property
    def footprint_area(self) -> float:
        """Area of the footprint on the belt [m^2]."""
        kind, a, b = self.footprint
        if kind == "rect":
            return 4 * a * b
        if kind == "disc":
            return math.pi * a * a
        return 4 * a * b + math.pi * b * b

    @property
    def half_length(self) -> float:
        """Half the footprint's extent along the body x axis [m]."""
        kind, a, b = self.footprint
        return a + b if kind == "stadium" else a

    @property
    def half_width(self) -> float:
        """Half the footprint's extent along the body y axis [m]."""
        return self.footprint[2]

    @property
    def rest_height(self) -> float:
        """Height of the body origin above the belt when the item rests on it [m]."""
        if self.shape == "box":
            return self.size[2]
        return self.size[1] if self.pose == "standing" else self.size[0]

    @property
    def geom_quat(self) -> tuple[float, float, float, float]:
        """Orientation (w, x, y, z) of the geom in the body frame."""
        return LYING_QUAT if self.pose == "lying" else (1.0, 0.0, 0.0, 0.0)

    def half_extents(self, yaw: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Half extents (along x, along y) [m] of the footprint's bounding box at `yaw` [rad]."""
        c, s = np.abs(np.cos(yaw)), np.abs(np.sin(yaw))
        kind, a, b = self.footprint
        if kind == "disc":
            return a + 0 * c, a + 0 * c
        if kind == "stadium":
            return a * c + b, a * s + b
        return a * c + b * s, a * s + b * c


@dataclass(frozen=True)
class Catalogue:
    """All item types and the colour table.

    Attributes:
        types: Item types, in file order (a type's index is its id in flows).
        rgba: RGBA of each colour of `perception.codes.COLOURS`, same order.
        materials: The material classes (one bin each) and their default values; the thesis's
            paper, plastic and aluminium unless the file has `[[material]]` entries.
    """

    types: tuple[ItemType, ...]
    rgba: tuple[tuple[float, float, float, float], ...]
    materials: Materials = THESIS_MATERIALS

    def __post_init__(self):
        if not self.types:
            raise InvalidInput("item", "at least one item type", 0)
        names = [t.name for t in self.types]
        if len(set(names)) != len(names):
            raise InvalidInput("item.name", "unique names", names)
        known = self.materials.names
        for t in self.types:
            if t.material not in known:
                allowed = "one of the materials " + "/".join(known)
                raise InvalidInput("material", allowed, t.material, f"item {t.name!r}")
        missing = [m for m in known if not any(t.material == m for t in self.types)]
        if missing:
            raise InvalidInput(
                "item.material", f"at least one item of every material {known}", missing
            )
        typed = tuple(
            t
            if t.class_id == self.materials.id_of(t.material)
            else dataclasses.replace(t, class_id=self.materials.id_of(t.material))
            for t in self.types
        )
        object.__setattr__(self, "types", typed)
        if len(self.rgba) != len(COLOURS):
            raise InvalidInput("colours", f"one RGBA per colour of {COLOURS}", len(self.rgba))
        seen_variant = False
        for item_type in self.types:
            where = f"item {item_type.name!r}"
            if not item_type.variant_of:
                # Base types first, so their indices (flows' type ids) do not move.
                if seen_variant:
                    raise InvalidInput("variant_of", "variants after every base type", "", where)
                continue
            seen_variant = True
            base = [t for t in self.types if t.name == item_type.variant_of and not t.variant_of]
            if not base:
                raise InvalidInput(
                    "variant_of", "the name of a base type", item_type.variant_of, where
                )
            twins = [t for t in self.types if t.variant_of == item_type.variant_of]
            if sum(t.kind == item_type.kind for t in twins) > 1:
                raise InvalidInput(
                    "kind", "one variant of each kind per base type", item_type.kind, where
                )

    @functools.cached_property
    def digest(self) -> str:
        """SHA-256 (16 hex characters) of the catalogue's content (types, colours, materials):
        the key under which what is trained or recorded from it is cached."""
        return hashlib.sha256(repr((self.types, self.rgba, self.materials)).encode()).hexdigest()[
            :16
        ]

    def index(self, name: str) -> int:
        """Index of the item type called `name`."""
        for i, item_type in enumerate(self.types):
            if item_type.name == name:
                return i
        raise InvalidInput("item", "/".join(t.name for t in self.types), name)

    def of_material(self, material: str) -> tuple[int, ...]:
        """Indices of the base types (not the shape variants) of one material."""
        return tuple(
            i for i, t in enumerate(self.types) if t.material == material and not t.variant_of
        )

    def variants(self, kind: str) -> np.ndarray:
        """Per type index, the index of its variant of `kind`, or -1 for none."""
        out = np.full(len(self.types), -1, dtype=np.int64)
        for i, item_type in enumerate(self.types):
            if item_type.kind == kind:
                out[self.index(item_type.variant_of)] = i
        return out

    def colour_rgba(self, colour: str | int) -> tuple[float, float, float, float]:
        """RGBA of a colour name or index of `perception.codes.COLOURS`."""
        return self.rgba[colour if isinstance(colour, int) else COLOURS.index(colour)]


def _numbers(entry: dict, key: str, where: str, count: int | None = None) -> tuple[float, ...]:
    value = entry[key]
    ok = isinstance(value, list) and all(is_finite_number(v) for v in value)
    if not ok or (count is not None and len(value) != count):
        what = f"{count} finite numbers" if count else "a list of finite numbers"
        raise InvalidInput(key, what, value, where)
    return tuple(float(v) for v in value)


def _number(entry: dict, key: str, where: str) -> float:
    value = entry[key]
    if not is_finite_number(value):
        raise InvalidInput(key, "a finite number", value, where)
    return float(value)


def _text(entry: dict, key: str, where: str) -> str:
    value = entry[key]
    if not isinstance(value, str) or not value.strip():
        raise InvalidInput(key, "a non-empty string", value, where)
    return value


def _colour_probs(weights: Any, where: str) -> tuple[float, ...]:
    ok = isinstance(weights, dict) and weights and set(weights) <= set(COLOURS)
    ok = ok and all(is_finite_number(w) and w >= 0 for w in weights.values())
    if not ok or sum(weights.values()) <= 0:
        raise InvalidInput("colours", f"non-negative weights over {COLOURS}", weights, where)
    total = float(sum(weights.values()))
    return tuple(float(weights.get(c, 0.0)) / total for c in COLOURS)


_ITEM_KEYS = ("name", "material", "shape", "pose", "size", "mass", "friction", "weight", "colours")
_VARIANT_KEYS = ("name", "variant_of", "kind", "shape", "pose", "size", "mass", "friction")


def _item_type(entry: object, index: int, path: Path, bases: dict[str, ItemType]) -> ItemType:
    if not isinstance(entry, dict):
        raise InvalidInput("item", "an array of tables [[item]]", type(entry).__name__, str(path))
    name = entry.get("name", "?")
    where = f"{path}, item {name!r}" if isinstance(name, str) else f"{path}, item {index}"
    keys = _VARIANT_KEYS if "variant_of" in entry else _ITEM_KEYS
    for key in keys:
        if key not in entry:
            raise InvalidInput(key, "present in every [[item]]", None, where)
    extra = set(entry) - set(keys)
    if extra:
        raise InvalidInput(sorted(extra)[0], f"only the keys {keys}", None, where)
    try:
        if "variant_of" in entry:
            # A variant is drawn in place of its base: same material, weight and colours.
            base_name = _text(entry, "variant_of", where)
            if base_name not in bases:
                raise InvalidInput("variant_of", "the name of a base type above", base_name, where)
            base = bases[base_name]
            inherited: dict[str, Any] = {"material": base.material, "weight": base.weight}
            inherited |= {"colour_probs": base.colour_probs, "variant_of": base_name}
            inherited["kind"] = _text(entry, "kind", where)
        else:
            inherited = {
                "material": _text(entry, "material", where),
                "weight": _number(entry, "weight", where),
                "colour_probs": _colour_probs(entry["colours"], where),
            }
        return ItemType(
            name=_text(entry, "name", where),
            shape=_text(entry, "shape", where),
            pose=_text(entry, "pose", where),
            size=_numbers(entry, "size", where),
            mass=_number(entry, "mass", where),
            friction=cast(tuple[float, float, float], _numbers(entry, "friction", where, 3)),
            **inherited,
        )
    except InvalidInput as exc:
        if exc.where == where:
            raise
        raise InvalidInput(exc.field, exc.allowed, exc.got, where) from None


def _materials(entries: object, path: Path) -> Materials:
    """The `[[material]]` entries (name, value_eur), in file order; the thesis's when absent."""
    if entries is None:
        return THESIS_MATERIALS
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise InvalidInput("material", "an array of tables [[material]]", None, str(path))
    for k, entry in enumerate(entries):
        where = f"{path}, material {k}"
        extra = set(entry) - {"name", "value_eur"}
        if extra or set(entry) != {"name", "value_eur"}:
            got = sorted(extra) if extra else sorted(entry)
            raise InvalidInput("material", "the keys name and value_eur", got, where)
        if not is_finite_number(entry["value_eur"]) or not 0 <= entry["value_eur"] <= 1e6:
            raise InvalidInput("material.value_eur", "0..1e6 EUR", entry["value_eur"], where)
    try:
        return Materials(
            tuple(e["name"] for e in entries), tuple(float(e["value_eur"]) for e in entries)
        )
    except ValueError as exc:
        allowed = str(exc).split("allowed ", 1)[-1]
        raise InvalidInput("material.name", allowed, None, str(path)) from None


DEFAULT_CATALOGUE = DATA_DIR / "items.toml"
"""The thesis's catalogue: paper, plastic and aluminium."""


def load_catalogue(path: Path | str = DEFAULT_CATALOGUE) -> Catalogue:
    """Reads and validates an item catalogue.

    Args:
        path: TOML file (UTF-8) with a [colours] table and [[item]] entries.

    Raises:
        InvalidInput: An unreadable file, not UTF-8 or not TOML, or a missing, malformed,
            non-finite or out-of-range field; one line naming the field and the file.
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
        data = tomllib.loads(text)
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise InvalidInput("catalogue", "a readable TOML file", f"{path}: {reason}") from None
    except UnicodeDecodeError as error:
        got = f"{path}: not UTF-8 at byte {error.start}"
        raise InvalidInput("catalogue", "a UTF-8 TOML file", got) from None
    except tomllib.TOMLDecodeError as error:
        reason = " ".join(str(error).split())
        raise InvalidInput("catalogue", "a readable TOML file", f"{path}: {reason}") from None
    colours = data.get("colours", {})
    if not isinstance(colours, dict) or set(colours) != set(COLOURS):
        names = sorted(colours) if isinstance(colours, dict) else colours
        raise InvalidInput("colours", f"exactly the names {COLOURS}", names, str(path))
    rgba: list[tuple[float, float, float, float]] = []
    for name in COLOURS:
        value = colours[name]
        ok = isinstance(value, list) and len(value) == 4
        if not ok or not all(is_finite_number(v) and 0 <= v <= 1 for v in value):
            raise InvalidInput(f"colours.{name}", "4 numbers in [0, 1]", value, str(path))
        rgba.append(cast(tuple[float, float, float, float], tuple(float(v) for v in value)))
    items = data.get("item", [])
    if not isinstance(items, list):
        raise InvalidInput("item", "an array of tables [[item]]", type(items).__name__, str(path))
    extra = set(data) - {"colours", "item", "material"}
    if extra:
        allowed = "only [colours], [[material]] and [[item]]"
        raise InvalidInput(sorted(extra)[0], allowed, None, str(path))
    materials = _materials(data.get("material"), path)
    bases: dict[str, ItemType] = {}
    types: list[ItemType] = []
    for i, entry in enumerate(items):
        item_type = _item_type(entry, i, path, bases)
        if not item_type.variant_of:
            bases[item_type.name] = item_type
        types.append(item_type)
    try:
        return Catalogue(types=tuple(types), rgba=tuple(rgba), materials=materials)
    except InvalidInput as exc:
        raise InvalidInput(exc.field, exc.allowed, exc.got, str(path)) from None
