"""Shared fixtures: the compiled cell, the cell's scene at its home keyframe, the catalogue.

The suite keeps its caches (stripe HMMs, item classifier, lens maps; `sim.user_cache`) in one
temporary folder for the whole session, shared by xdist's workers and by the commands the
tests start (they inherit the environment), and removed at the end: the suite writes nothing
into the checkout or the user's own cache folder, and makes each cache once (about 10 s of
CPU). A `SORTSIM_CACHE_DIR` already set is used as it is (a folder kept between sessions
saves those seconds).
"""

from __future__ import annotations

import os
import shutil
import tempfile

import pytest

from sim.cell.cell import Cell
from sim.flow.catalogue import load_catalogue
from tests.utils import scene_at_home


def pytest_configure(config):
    if os.environ.get("SORTSIM_CACHE_DIR"):
        return
    folder = tempfile.mkdtemp(prefix="sortsim-test-cache-")  # mode 0o700
    os.environ["SORTSIM_CACHE_DIR"] = folder
    config._sortsim_cache = folder  # removed by this process only (xdist's workers inherit it)


def pytest_unconfigure(config):
    folder = getattr(config, "_sortsim_cache", None)
    if folder is not None:
        shutil.rmtree(folder, ignore_errors=True)


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
