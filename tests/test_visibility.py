"""The visible fraction of an item's top area (sim.monitors.visibility) and `never_visible`."""

from __future__ import annotations

import mujoco
import pytest

from sim.cell.camera import FRAME_SIZE
from sim.episode import config
from sim.episode.builder import belt_cameras
from sim.episode.runner import run_episode
from sim.flow.config import X_CAMERA
from sim.monitors.visibility import SCALE, VISIBLE_SHARE, VisibilityWatch, belt_slope
from sim.render.segmentation import shared_segmentation
from sim.results import outputs
from sim.results.metrics import EpisodeMetrics

WHITE, RED = (0.93, 0.93, 0.91, 1.0), (0.8, 0.1, 0.1, 1.0)
ALONE_TOLERANCE = 0.04
"""An item alone in view is seen whole within this (the render's pixels against its computed
silhouette at the monitor's half scale: 0.98-1.00 measured over every catalogue type)."""


@pytest.fixture(scope="module")
def watch(cell):
    """The episode's visibility watch on the module's cell (the monitor's render settings)."""
    height = 0.75  # the camera above the belt [m]
    render = shared_segmentation(cell.model, cell.pool, FRAME_SIZE, SCALE, belt_slope(height))
    return VisibilityWatch([render], cell.items)


def _scene(cell, items):
    """The cell reset with `items` (type name, x, y, yaw, colour, z_drop) lying still."""
    cell.reset(0.185)
    names = [t.name for t in cell.catalogue.types]
    for item_id, (name, x, y, yaw, rgba, z_drop) in enumerate(items):
        cell.pool.spawn(cell.data, item_id, names.index(name), x, y, yaw, rgba, z_drop=z_drop)
    mujoco.mj_forward(cell.model, cell.data)


def _raw(watch, item_id):
    """The item's visible pixels over its computed silhouette, unclipped."""
    render = watch.renders[0]
    counts = render.pixel_counts(watch.items.current())
    _, areas = watch.fractions(render, counts)
    return counts[watch.pool.slot_of(item_id)] / areas[item_id]


@pytest.mark.parametrize("dx, y", [(-0.15, -0.2), (0.0, 0.0), (0.15, 0.2)])
def test_an_item_alone_is_seen_whole(cell, watch, dx, y):
    for k, item_type in enumerate(cell.catalogue.types):
        _scene(cell, [(item_type.name, X_CAMERA + dx, y, 0.7 * k, RED, 0.0)])
        sighting = watch.measure()
        assert sighting.fractions[0] > 1.0 - ALONE_TOLERANCE, item_type.name
        assert _raw(watch, 0) < 1.0 + ALONE_TOLERANCE, item_type.name
        assert sighting.passed == ((0,) if dx >= 0.0 else ())


def test_an_item_under_a_flat_item_is_hidden(cell, watch):
    scrap_top = 0.002  # the paper scrap's thickness [m]: the sheet lies on it
    _scene(
        cell,
        [
            ("paper_scrap", X_CAMERA, 0.0, 0.0, RED, 0.0),
            ("paper_sheet_a4", X_CAMERA, 0.0, 0.0, WHITE, scrap_top),
        ],
    )
    fractions = watch.measure().fractions
    assert fractions[0] < 0.02
    assert fractions[1] > 1.0 - ALONE_TOLERANCE


def test_an_item_half_under_a_flat_item_is_half_seen(cell, watch):
    sheet_half_length = 0.1485  # A4 along x [m]: the scrap's centre on the sheet's edge
    _scene(
        cell,
        [
            ("paper_scrap", X_CAMERA + sheet_half_length, 0.0, 0.0, RED, 0.0),
            ("paper_sheet_a4", X_CAMERA, 0.0, 0.0, WHITE, 0.002),
        ],
    )
    assert watch.measure().fractions[0] == pytest.approx(0.5, abs=0.05)


def test_an_item_outside_the_frame_is_not_seen(cell, watch):
    _scene(cell, [("can_330_standing", X_CAMERA - 0.8, 0.0, 0.0, RED, 0.0)])
    assert watch.measure().fractions.get(0, 0.0) == 0.0


def test_the_cell_has_one_belt_camera(cell):
    assert belt_cameras(cell) == ("belt_camera",)


def test_never_visible_counts_items_passed_and_never_seen_enough():
    m = EpisodeMetrics({2: 0.02, 3: 0.02, 4: 0.1})
    assert m.row()["never_visible"] is None  # truth perception: not measured
    for item_id in range(4):
        m.on_entered(item_id, 2)
    m.on_visibility({})
    assert m.row()["never_visible"] == 0
    m.on_visibility({0: 0.1, 1: 0.9, 2: 0.2}, passed=(0, 1))
    m.on_visibility({0: 0.25, 2: VISIBLE_SHARE}, passed=(0, 1, 2))
    # 0: at most 25 %; 1 and 2 seen enough once; 3 never passed the camera
    assert m.row()["never_visible"] == 1
    m.on_visibility({3: 0.0}, passed=(3,))
    assert m.row()["never_visible"] == 2
    for item_id in range(4):
        m.on_missed(item_id)
    assert m.accounting_failures() == []
    text = outputs.to_csv_text(outputs.EPISODE_COLUMNS, [m.row()])
    cells = dict(zip(*(line.split(",") for line in text.splitlines()), strict=True))
    assert cells["never_visible"] == "2"
    columns = outputs.EPISODE_COLUMNS
    assert columns.index("never_visible") == columns.index("never_detected") + 1


def test_truth_perception_leaves_never_visible_empty(cell):
    result = run_episode(config.load(None, items=4, duration_s=2.0, perception="truth"), cell=cell)
    assert result.episode_row["never_visible"] is None
    assert "visibility" not in result.timings


@pytest.mark.slow
def test_a_camera_episode_counts_never_visible(cell):
    result = run_episode(config.load(None, items=8, duration_s=4.0, perception="camera"), cell=cell)
    row = result.episode_row
    assert 0 <= row["never_visible"] <= row["entered"] == 8
    assert result.timings["visibility"] > 0.0
