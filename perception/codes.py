"""The class vocabulary: the thesis's classes (table 3.1), their values (table 3.3) and
observation codes (table 3.2), the one home that perception, the planner and the cell all read.

Codes 1..18 are size x colour, size-major: small 1-6, medium 7-12, large 13-18, colours in the
order transparent, brown, white, blue, red, green; code 19 is an empty cell (black belt).
Size classes by the fraction of the cell an item covers (thesis 3.2.1): small 1-25 %, medium
up to 65 %, large above; under 1 % the cell counts as empty.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from perception.errors import PerceptionInputError

CLASS_NAMES = ("void", "paper", "plastic", "aluminium")
VOID, PAPER, PLASTIC, ALUMINIUM = 1, 2, 3, 4
N_STATES = 4
MATERIALS = (PAPER, PLASTIC, ALUMINIUM)
"""The material classes, one bin each, in the order every value tuple uses."""
THESIS_VALUES_EUR = (0.22, 0.25, 0.27)
"""Value of an item of each material [EUR] (thesis table 3.3), in the order of MATERIALS."""
MAX_MATERIALS = 8
"""Most material classes (bins) a cell may sort."""
_MATERIAL_NAME = re.compile(r"[a-z][a-z0-9_]{0,23}")


@dataclass(frozen=True)
class Materials:
    """The material classes a cell sorts, one bin each; data, not code (an item catalogue's
    `[[material]]` entries). Class ids follow table 3.1's scheme: 1 is void (the empty belt),
    materials are 2, 3, ... in this order; probability vectors are (void, *materials).

    Attributes:
        names: Material names, lowercase identifiers (column suffixes: `picked_<name>`).
        values_eur: Default value of an item of each material [EUR].
    """

    names: tuple[str, ...] = CLASS_NAMES[1:]
    values_eur: tuple[float, ...] = THESIS_VALUES_EUR

    def __post_init__(self) -> None:
        names, values = tuple(self.names), tuple(self.values_eur)
        if not 1 <= len(names) <= MAX_MATERIALS:
            raise PerceptionInputError("materials", f"1..{MAX_MATERIALS}", len(names))
        for name in names:
            if not isinstance(name, str) or not _MATERIAL_NAME.fullmatch(name):
                allowed = "a lowercase identifier of up to 24 characters"
                raise PerceptionInputError("material name", allowed, name)
        if len(set(names)) != len(names) or {"void", "none"} & set(names):
            raise PerceptionInputError("material names", "unique names, not void/none", names)
        ok = len(values) == len(names) and all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v >= 0
            for v in values
        )
        if not ok:
            raise PerceptionInputError("material values", "one finite value >= 0 EUR each", values)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "values_eur", tuple(float(v) for v in values))

    @property
    def count(self) -> int:
        """Number of materials (bins)."""
        return len(self.names)

    @property
    def n_states(self) -> int:
        """Classes of a grid cell: void and every material (the HMMs' hidden states)."""
        return len(self.names) + 1

    @property
    def ids(self) -> tuple[int, ...]:
        """Class ids of the materials: 2, 3, ..."""
        return tuple(range(2, 2 + len(self.names)))

    @property
    def class_names(self) -> tuple[str, ...]:
        """Name of every class id 1.. : ("void", *names)."""
        return ("void", *self.names)

    def id_of(self, name: str) -> int:
        """Class id of material `name`."""
        return 2 + self.names.index(name)

    def name_of(self, class_id: int | None) -> str:
        """Name of a class id; "none" for None or 0."""
        if not class_id:
            return "none"
        return self.class_names[int(class_id) - 1]

    @property
    def is_thesis(self) -> bool:
        """The thesis's paper, plastic and aluminium (in that order)."""
        return self.names == CLASS_NAMES[1:]


THESIS_MATERIALS = Materials()
"""The thesis's three materials and values (tables 3.1, 3.3): the default everywhere."""

COLOURS = ("transparent", "brown", "white", "blue", "red", "green")
SIZES = ("small", "medium", "large")
N_CODES = 19
EMPTY_CODE = 19

MIN_FRACTION = 0.01
SMALL_MAX = 0.25
MEDIUM_MAX = 0.65


def observation_code(size: str, colour: str) -> int:
    """Code 1..18 of a size and a colour name (table 3.2)."""
    return 1 + SIZES.index(size) * len(COLOURS) + COLOURS.index(colour)


def size_class(fraction: float) -> str | None:
    """Size class of an item covering `fraction` [0..1] of a cell; None when under 1 %."""
    if fraction < MIN_FRACTION:
        return None
    if fraction <= SMALL_MAX:
        return "small"
    if fraction <= MEDIUM_MAX:
        return "medium"
    return "large"


def code_of_cell(fraction: float, colour: str) -> int:
    """Observation code of a cell covered `fraction` [0..1] by an item of `colour`."""
    size = size_class(fraction)
    return EMPTY_CODE if size is None else observation_code(size, colour)


def decode(code: int) -> tuple[str, str] | None:
    """(size, colour) of a code 1..18; None for the empty code 19."""
    if code == EMPTY_CODE:
        return None
    if not 1 <= code < EMPTY_CODE:
        raise PerceptionInputError("observation code", "1..19", code)
    size_index, colour_index = divmod(code - 1, len(COLOURS))
    return SIZES[size_index], COLOURS[colour_index]


def codes_table() -> np.ndarray:
    """(19,) array of 'size colour' labels, index code-1, for reports."""
    labels = [f"{s} {c}" for s in SIZES for c in COLOURS] + ["none black"]
    return np.array(labels)
