"""The class vocabulary: the thesis's classes (table 3.1), their values (table 3.3) and
observation codes (table 3.2), the one home that perception, the planner and the cell all read.

Codes 1..18 are size x colour, size-major: small 1-6, medium 7-12, large 13-18, colours in the
order transparent, brown, white, blue, red, green; code 19 is an empty cell (black belt).
Size classes by the fraction of the cell an item covers (thesis 3.2.1): small 1-25 %, medium
up to 65 %, large above; under 1 % the cell counts as empty.
"""

from __future__ import annotations

import numpy as np

CLASS_NAMES = ("void", "paper", "plastic", "aluminium")
VOID, PAPER, PLASTIC, ALUMINIUM = 1, 2, 3, 4
N_STATES = 4
MATERIALS = (PAPER, PLASTIC, ALUMINIUM)
"""The material classes, one bin each, in the order every value tuple uses."""
THESIS_VALUES_EUR = (0.22, 0.25, 0.27)
"""Value of an item of each material [EUR] (thesis table 3.3), in the order of MATERIALS."""

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
        raise ValueError(f"observation code: allowed 1..19 (got {code})")
    size_index, colour_index = divmod(code - 1, len(COLOURS))
    return SIZES[size_index], COLOURS[colour_index]


def codes_table() -> np.ndarray:
    """(19,) array of 'size colour' labels, index code-1, for reports."""
    labels = [f"{s} {c}" for s in SIZES for c in COLOURS] + ["none black"]
    return np.array(labels)
