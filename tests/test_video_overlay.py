"""The video's annotations: labels never overlap (a crowded item keeps its dot), the bins'
running purity, the see-through cage."""

from __future__ import annotations

import numpy as np

from sim.render.labels import LABEL_OFFSETS, Overlay, annotate, place_label, purity_text
from sim.render.view import GHOSTED_PREFIXES, ghosted_geoms


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
    assert frame[10, 10].any()  # the counters' text


def test_purity_text():
    binned = {1: (2, 2), 2: (3, 2), 3: (3, 3)}  # paper bin: one paper, one plastic
    assert purity_text(binned) == "PAP 0.50  PL 1.00  AL -"


def test_the_cage_and_camera_box_are_ghosted(cell):
    ids = ghosted_geoms(cell.model)
    names = {cell.model.geom(i).name for i in ids}
    assert "cage_post_upstream_left" in names and "camera_box_top" in names
    assert all(n.startswith(GHOSTED_PREFIXES) for n in names)
    assert len(ids) >= 10
