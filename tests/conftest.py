"""Shared fixtures: the compiled cell, the cell's scene at its home keyframe, the catalogue."""

from __future__ import annotations

import pytest

from sim.cell.cell import Cell
from sim.flow.catalogue import load_catalogue
from tests.utils import scene_at_home


@pytest.fixture(scope="session")
def catalogue():
    """The item catalogue of `sim/data/items.toml`."""
    return load_catalogue()


@pytest.fixture(scope="module")
def cell() -> Cell:
    """A compiled cell, shared by one test module (each episode resets it)."""
    return Cell()


@pytest.fixture
def scene():
    """(model, data) of the cell's scene, robot at its `home` keyframe, kinematics done."""
    return scene_at_home()
