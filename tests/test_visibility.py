"""The visible fraction of an item's top area (sim.monitors.visibility) and `never_visible`."""

from __future__ import annotations

import math

import cv2
import mujoco
import numpy as np
import pytest

from sim import config
from sim.cell.camera import camera_id, camera_pose, renderer_with_samples
from sim.config.plant import FRAME_SIZE
from sim.episode.builder import belt_cameras, visibility_monitor
from sim.episode.runner import run_episode
from sim.flow.config import X_CAMERA
from sim.monitors import visibility
from sim.monitors.visibility import SCALE, VISIBLE_SHARE, VisibilityWatch, belt_slope
from sim.render.segmentation import NO_ITEM, BeltSegmentation, shared_segmentation, slot_of_geom
from sim.results import outputs
from sim.results.metrics import EpisodeMetrics

WHITE, RED = (0.93, 0.93, 0.91, 1.0), (0.8, 0.1, 0.1, 1.0)
ALONE_TOLERANCE = 0.04
"""An item alone in view is seen whole within this (the render's pixels against its computed
silhouette at the monitor's half scale: 0.98-1.00 measured over every catalogue type)."""


HEIGHT = 0.75
"""The camera above the belt [m]."""


@pytest.fixture(scope="module")
def watch(cell):
    """The episode's visibility watch on the module's cell (the monitor's render settings, in
    the renderer of the cell's belt cameras)."""
    renderer = cell.belt_camera(FRAME_SIZE).renderer
    render = shared_segmentation(
        cell.model, cell.pool, FRAME_SIZE, SCALE, belt_slope(HEIGHT), renderer=renderer
    )
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


def _mixed_scene(cell):
    """Every catalogue type on the belt around the camera, round ones with a printed label,
    some overlapping, one under the robot's base downstream."""
    names = [t.name for t in cell.catalogue.types]
    cell.reset(0.185)
    rng = np.random.default_rng(7)
    for item_id, name in enumerate(names):
        x, y = X_CAMERA + rng.uniform(-0.3, 0.3), rng.uniform(-0.25, 0.25)
        label = (0.1, 0.3, 0.8, 1.0) if item_id % 2 else None
        cell.pool.spawn(cell.data, item_id, names.index(name), x, y, rng.uniform(0, 3), RED,
                        label_rgba=label, z_drop=0.0)  # fmt: skip
    mujoco.mj_forward(cell.model, cell.data)


def _reference_slots(seg: BeltSegmentation, data) -> np.ndarray:
    """The slots of `seg`'s view as `mujoco.Renderer`'s segmentation render of the whole scene
    on a context of its own shows them (how the monitor rendered them before it shared the
    cameras' renderer and culled its scene)."""
    model = seg.model
    cam = camera_id(model, seg.name)
    renderer = renderer_with_samples(model, *seg.size, 0)
    flags = renderer.scene.flags
    flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
    flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = False
    fovy = float(model.cam_fovy[cam])
    model.cam_fovy[cam] = math.degrees(2.0 * math.atan(0.5 * seg.size[1] / seg._focal))
    try:
        renderer.update_scene(data, camera=cam, scene_option=seg._option)
        rgb = renderer.render()
        ids = rgb[..., 0] | (rgb[..., 1].astype(np.uint16) << 8)
        geoms = renderer.scene.geoms
        lookup = np.full(renderer.scene.ngeom + 1, NO_ITEM, dtype=np.int16)
        of_geom = slot_of_geom(model, seg.pool)
        for index in range(1, renderer.scene.ngeom + 1):
            if geoms[index - 1].objtype == mujoco.mjtObj.mjOBJ_GEOM:
                lookup[index] = of_geom[geoms[index - 1].objid]
    finally:
        model.cam_fovy[cam] = fovy
        renderer.close()
    return lookup[ids]


def test_the_segmentation_in_the_cameras_renderer_is_mujoco_renderers(cell, watch):
    """Rendered in the cell's cameras' renderer (a culled scene, the pixels read as RGBA), the
    monitor's segmentation (half scale, cropped, no static geoms) and a whole canvas's (the
    labelled frames') show each item on the same pixels as `mujoco.Renderer`'s segmentation
    render of the whole scene on a context of its own."""
    _mixed_scene(cell)
    data = cell.items.current()
    render = watch.renders[0]
    assert render.renderer is cell.belt_camera(FRAME_SIZE).renderer
    whole = BeltSegmentation(cell.model, cell.pool, FRAME_SIZE, renderer=render.renderer)
    for seg in (render, whole):
        slots = seg.render(data)
        reference = _reference_slots(seg, data)
        assert len(np.unique(reference)) > 5  # items in view, some behind others
        assert np.array_equal(slots, reference)
        inside = np.bincount(reference[seg.in_frame] + 1, minlength=cell.pool.size + 1)[1:]
        assert np.array_equal(seg.counts(reference), inside)
        assert np.array_equal(seg.pixel_counts(data), inside)
        noise = np.random.default_rng(3).integers(-1, 4, reference.shape).astype(np.int16)
        inside = np.bincount(noise[seg.in_frame] + 1, minlength=cell.pool.size + 1)[1:]
        assert np.array_equal(seg.counts(noise), inside)  # the frame is not symmetric
    whole.close()  # lent: the cameras' renderer stays open
    assert render.renderer._contexts


def test_the_monitor_renders_in_the_cells_cameras_renderer(cell):
    visibility_monitor(cell, FRAME_SIZE, EpisodeMetrics({}))
    kept = shared_segmentation(cell.model, cell.pool, FRAME_SIZE, SCALE, belt_slope(HEIGHT))
    assert kept.renderer is cell.belt_camera(FRAME_SIZE).renderer


def _one_by_one(watch, slot, rot, eye, k) -> float:
    """An item's silhouette area [px] from its own outline and its label sleeve's, one geom at
    a time (how the monitor measured it before measuring the items near a camera together)."""
    model, data = watch.model, watch.items.current()
    geom, label = int(watch.pool.active_geom[slot]), int(watch.pool.label_ids[slot])
    mat = data.geom_xmat[geom].reshape(3, 3)
    kind = int(model.geom_type[geom])
    item = visibility._hull(
        visibility.outline(kind, model.geom_size[geom], data.geom_xpos[geom], mat, eye), rot, eye, k
    )
    if item is None or model.geom_rgba[label, 3] <= 0.0:
        return 0.0 if item is None else float(cv2.contourArea(item))
    sleeve = visibility.outline(
        int(mujoco.mjtGeom.mjGEOM_CYLINDER), model.geom_size[label], *watch.label_frame(slot), eye
    )
    label_hull = visibility._hull(sleeve, rot, eye, k)
    if label_hull is None:
        return 0.0
    overlap, _ = cv2.intersectConvexConvex(item, label_hull)
    return float(cv2.contourArea(item) + cv2.contourArea(label_hull) - overlap)


def test_silhouettes_measured_together_are_those_measured_one_by_one(cell, watch):
    """Boxes, cylinders and label sleeves are outlined and projected together, capsules one by
    one: the same areas, bit for bit, from the camera and from anywhere else."""
    _mixed_scene(cell)
    slots = watch.items.active_slots()
    kinds = set(cell.model.geom_type[watch.pool.active_geom[slots]].tolist())
    assert len(kinds) == 3 and (cell.model.geom_rgba[watch.pool.label_ids[slots], 3] > 0).any()
    k = watch.renders[0].camera_matrix
    rot, eye = camera_pose(cell.model, cell.data)
    rng = np.random.default_rng(1)
    poses = [(rot, eye)]
    for _ in range(20):
        quat = rng.normal(size=4)
        turn = np.empty(9)
        mujoco.mju_quat2Mat(turn, quat / np.linalg.norm(quat))
        poses.append((turn.reshape(3, 3) @ rot, eye + rng.normal(scale=0.2, size=3)))
    seen = watch.silhouettes_px(slots, rot, eye, k)
    assert sum(area > 0.0 for area in seen) > 5
    for rot, eye in poses:
        together = watch.silhouettes_px(slots, rot, eye, k)
        one_by_one = [_one_by_one(watch, s, rot, eye, k) for s in slots.tolist()]
        assert np.array(together).tobytes() == np.array(one_by_one).tobytes()


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
