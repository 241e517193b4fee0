"""The item catalogue: loads, validates, and spans the thesis's cell-occupancy classes."""

import math

import numpy as np
import pytest

from perception.codes import COLOURS
from sim.errors import InvalidInput
from sim.flow.catalogue import MATERIALS, load_catalogue

STRIPE_WIDTH = 0.16
ROW_PITCHES = {1.0: 0.0925, 1.2: 0.111, 1.5: 0.13875}

GOOD_ITEM = """
[colours]
transparent = [0.8, 0.8, 0.9, 0.4]
brown = [0.5, 0.4, 0.2, 1]
white = [1, 1, 1, 1]
blue = [0, 0, 1, 1]
red = [1, 0, 0, 1]
green = [0, 1, 0, 1]
{items}
"""

ITEM = """
[[item]]
name = "{name}"
material = "{material}"
shape = "box"
pose = "flat"
size = [0.05, 0.04, 0.01]
mass = 0.01
friction = [0.5, 0.005, 0.0001]
weight = 1.0
colours = {{ white = 1.0 }}
"""


def _write(tmp_path, items_text):
    path = tmp_path / "items.toml"
    path.write_text(GOOD_ITEM.format(items=items_text))
    return path


def _three(**override):
    entries = []
    for material in MATERIALS:
        text = ITEM.format(name=material + "_thing", material=material)
        entries.append(text)
    text = "".join(entries)
    for key, (old, new) in override.items():
        assert old in text, key
        text = text.replace(old, new, 1)
    return text


def test_shipped_catalogue_loads_with_every_material():
    catalogue = load_catalogue()
    for material in MATERIALS:
        assert catalogue.of_material(material)
    for item_type in catalogue.types:
        assert math.isclose(sum(item_type.colour_probs), 1.0)
        assert 0.001 <= item_type.mass <= 0.1
        assert 0.3 <= item_type.friction[0] <= 0.7
    assert len(catalogue.rgba) == len(COLOURS)


def test_colours_overlap_between_classes():
    """Every colour but transparent is worn by at least two classes: colour alone is ambiguous."""
    catalogue = load_catalogue()
    for index, colour in enumerate(COLOURS):
        classes = {t.material for t in catalogue.types if t.colour_probs[index] > 0}
        if colour == "transparent":
            assert classes == {"plastic"}
        else:
            assert len(classes) >= 2, colour


@pytest.mark.parametrize("speed_factor", sorted(ROW_PITCHES))
def test_footprints_span_small_medium_large(speed_factor):
    cell_area = STRIPE_WIDTH * ROW_PITCHES[speed_factor]
    ratios = np.array([t.footprint_area / cell_area for t in load_catalogue().types])
    assert (ratios < 0.25).any()
    assert ((ratios > 0.25) & (ratios <= 0.65)).any()
    assert (ratios > 1.0).any()


def test_footprint_geometry_of_a_lying_capsule():
    bottle = load_catalogue().types[load_catalogue().index("pet_bottle_0l5")]
    radius, half = bottle.size
    assert bottle.footprint == ("stadium", half, radius)
    assert bottle.half_length == pytest.approx(0.1025)
    assert bottle.rest_height == radius
    ex, ey = bottle.half_extents(math.pi / 2)
    assert ex == pytest.approx(radius) and ey == pytest.approx(half + radius)
    w, x, y, z = bottle.geom_quat
    assert w == pytest.approx(math.sqrt(0.5)) and y == pytest.approx(math.sqrt(0.5))


def test_small_valid_file_loads(tmp_path):
    catalogue = load_catalogue(_write(tmp_path, _three()))
    assert [t.class_id for t in catalogue.types] == [2, 3, 4]
    assert catalogue.colour_rgba("white") == (1.0, 1.0, 1.0, 1.0)


@pytest.mark.parametrize(
    ("old", "new", "field"),
    [
        ('material = "paper"', 'material = "glass"', "material"),
        ('shape = "box"', 'shape = "sphere"', "shape"),
        ('pose = "flat"', 'pose = "standing"', "pose"),
        ("size = [0.05, 0.04, 0.01]", "size = [0.05, 0.04]", "size"),
        ("mass = 0.01", "mass = -1", "mass"),
        ("weight = 1.0", "weight = 0", "weight"),
        ("white = 1.0", "purple = 1.0", "colours"),
        ('name = "plastic_thing"', 'name = "paper_thing"', "item.name"),
    ],
)
def test_bad_fields_are_refused_by_name(tmp_path, old, new, field):
    with pytest.raises(InvalidInput) as error:
        load_catalogue(_write(tmp_path, _three(x=(old, new))))
    assert error.value.field == field


def test_missing_key_and_missing_material_are_refused(tmp_path):
    with pytest.raises(InvalidInput, match="friction"):
        load_catalogue(_write(tmp_path, _three(x=("friction = [0.5, 0.005, 0.0001]\n", ""))))
    one = ITEM.format(name="a", material="paper")
    with pytest.raises(InvalidInput, match="material"):
        load_catalogue(_write(tmp_path, one))
    with pytest.raises(InvalidInput, match="catalogue"):
        load_catalogue(tmp_path / "absent.toml")
