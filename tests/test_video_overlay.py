"""The video's annotations: labels never overlap (a crowded item keeps its dot), text sized to
the frame, the bins labelled with their material and count (wrong ones apart), the wrong-bin
counter, the bins' running purity, the see-through cage, a view that sees the pick zone."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.render.labels import (
    LABEL_OFFSETS,
    WRONG_COLOUR,
    BinLabel,
    Overlay,
    annotate,
    place_label,
    purity_text,
)
from sim.render.view import GHOSTED_PREFIXES, ghosted_geoms, view_camera


def test_labels_of_a_cluster_do_not_overlap():
    taken: list = []
    corners = [place_label((100, 100), (20, 8), taken) for _ in range(12)]
    placed = [c for c in corners if c is not None]
    assert len(placed) == len(LABEL_OFFSETS)  # then no room is left: dots only
    boxes = taken
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            assert not (a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3])


def test_annotate_draws_every_dot_and_the_panel():
    frame = np.zeros((120, 200, 3), dtype=np.uint8)
    items = [(k, 0.0, 0.0, 0.0, 2 + k % 3, 1.0) for k in range(6)]
    uv = np.array([[100.0 + k, 60.0] for k in range(6)])
    overlay = Overlay(items=items, next_pick=3, counters=["profit 1.00 EUR"])
    annotate(frame, uv, overlay)
    assert frame[60, 100:106].any()  # the dots
    assert frame[:20, :80].any()  # the counters' text


def _drawn(height: int, overlay: Overlay, bin_uv=None) -> np.ndarray:
    frame = np.zeros((height, height * 16 // 9, 3), dtype=np.uint8)
    return annotate(frame, np.zeros((0, 2)), overlay, bin_uv)


def test_text_grows_with_the_frame():
    overlay = Overlay(counters=["profit 1.00 EUR", "wrong bin 0"])
    small, large = _drawn(360, overlay), _drawn(720, overlay)
    rows = [np.flatnonzero(f.max(axis=(1, 2)) == 255) for f in (small, large)]
    cols = [np.flatnonzero(f.max(axis=(0, 2)) == 255) for f in (small, large)]
    assert rows[1].max() == pytest.approx(2 * rows[0].max(), rel=0.15)
    assert cols[1].max() == pytest.approx(2 * cols[0].max(), rel=0.15)
    assert rows[0].max() > 30  # two lines of larger text than before (16 px a line)


def test_bins_are_labelled_with_their_material_count_and_wrong_items():
    bins = [BinLabel(2, 0.0, -0.6, -0.05, 5, 0), BinLabel(3, -0.2, 0.55, -0.05, 7, 2)]
    overlay = Overlay(bins=bins, counters=["wrong bin 2"], wrong_line=0)
    uv = np.array([[300.0, 300.0], [200.0, 150.0]])
    frame = _drawn(360, overlay, uv)
    paper = np.array((230, 170, 60))
    near_paper = frame[270:305, 240:360].reshape(-1, 3)
    assert (np.abs(near_paper.astype(int) - paper).sum(axis=1) < 30).sum() > 40  # its box, text
    red = np.abs(frame.astype(int) - WRONG_COLOUR).sum(axis=2) < 30
    assert red[120:155, 150:330].sum() > 20  # "2 wrong" beside the plastic bin's count
    assert red[:25, :200].sum() > 20  # the wrong-bin counter in red
    assert not red[270:305, 240:360].any()  # none wrong in the paper bin


def test_purity_text():
    binned = {1: (2, 2), 2: (3, 2), 3: (3, 3)}  # paper bin: one paper, one plastic
    assert purity_text(binned) == "PAP 0.50  PL 1.00  AL -"


def test_the_cage_and_camera_box_are_ghosted(cell):
    ids = ghosted_geoms(cell.model)
    names = {cell.model.geom(i).name for i in ids}
    assert "cage_post_upstream_left" in names and "camera_box_top" in names
    assert all(n.startswith(GHOSTED_PREFIXES) for n in names)
    assert len(ids) >= 10


def test_the_view_sees_the_pick_zone_past_the_robots_base(cell):
    """From the video's camera, every line of sight to the belt in the robot's reach (x and y
    within 0.45 and 0.35 m of its axis) passes the base's height at least 0.6 m from its axis:
    clear of the base (0.26 m in radius) and of the upper arms (0.35 m from its 0.2 m motor
    circle). The view of before came within 0.35 m of it."""
    cam = view_camera(cell.model)
    az, el = np.radians(cam.azimuth), np.radians(cam.elevation)
    forward = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    eye = np.array(cam.lookat) - cam.distance * forward
    data = mujoco.MjData(cell.model)
    mujoco.mj_kinematics(cell.model, data)
    housing = cell.model.geom("base_housing").id
    axis = data.geom_xpos[housing]
    bottom = axis[2] - cell.model.geom_size[housing][1]
    closest = np.inf
    for x in np.linspace(-0.45, 0.45, 10):
        for y in np.linspace(-0.35, 0.35, 8):
            ray = np.array([x, y, 0.0]) - eye
            crossing = eye + (bottom - eye[2]) / ray[2] * ray
            closest = min(closest, np.hypot(*(crossing - axis)[:2]))
    assert closest > 0.6, closest
