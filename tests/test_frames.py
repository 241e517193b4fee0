"""`sortsim frames`: the belt camera's labelled frames, a COCO data set (sim.evaluation.frames)."""

from __future__ import annotations

import json
import os

import cv2
import mujoco
import numpy as np

from sim import config
from sim.cell.camera import camera_pose
from sim.cli.main import main
from sim.episode.runner import Episode, config_cell
from sim.evaluation import frames
from sim.flow.config import X_CAMERA

CENTROID_TOLERANCE_M = 0.025
"""How far from an item's true centre its mask's centroid may project (the belt plane at the
item's centre height), for an item seen whole (a tall item off the axis shows its flank)."""


def check_coco(folder, cell) -> dict:
    """Check the data set in `folder` as COCO and against the items' true positions; return it."""
    dataset = json.loads((folder / frames.ANNOTATIONS).read_text(encoding="utf-8"))
    assert set(dataset) >= {"info", "images", "annotations", "categories"}
    categories = {c["id"] for c in dataset["categories"]}
    assert categories == set(cell.materials.ids)
    images = {image["id"]: image for image in dataset["images"]}
    assert len(images) == len(dataset["images"])
    for image in images.values():
        rgb = cv2.imread(str(folder / image["file_name"]), cv2.IMREAD_UNCHANGED)
        depth = cv2.imread(str(folder / image["depth_file"]), cv2.IMREAD_UNCHANGED)
        assert rgb.shape == (image["height"], image["width"], 3) and rgb.dtype == np.uint8
        assert depth.shape == rgb.shape[:2] and depth.dtype == np.uint16
        belt = np.median(depth[depth > 0])
        assert 700 < belt < 800  # mm: the camera hangs 0.75 m above the belt
    camera = dataset["info"]["camera"]
    k, dist = np.array(camera["camera_matrix"]), np.array(camera["dist_coeffs"])
    rot, eye = camera_pose(cell.model, cell.data)
    ids = [a["id"] for a in dataset["annotations"]]
    assert len(set(ids)) == len(ids)
    for a in dataset["annotations"]:
        image = images[a["image_id"]]
        mask = frames.decode_rle(a["segmentation"])
        assert mask.shape == (image["height"], image["width"])
        assert a["area"] == int(mask.sum()) > 0
        x, y, w, h = a["bbox"]
        assert 0 <= x and 0 <= y and x + w <= image["width"] and y + h <= image["height"]
        assert a["bbox"] == frames.bbox_of(mask)
        assert a["category_id"] in categories and a["iscrowd"] == 0
        assert cell.catalogue.types[cell.catalogue.index(a["item_type"])]
        if a["visible_fraction"] > 0.95:
            assert _seen_at(mask, k, dist, rot, eye, a["position_m"]) < CENTROID_TOLERANCE_M
    return dataset


def _seen_at(mask, k, dist, rot, eye, position) -> float:
    """How far [m] the mask's centroid, undistorted and cast onto the plane at the item's
    centre height, lies from the item's centre."""
    rows, cols = np.nonzero(mask)
    pixel = np.array([[[cols.mean(), rows.mean()]]])
    ray = np.append(cv2.undistortPoints(pixel, k, dist).ravel(), 1.0)
    direction = rot @ ray
    point = eye + direction * (position[2] - eye[2]) / direction[2]
    return float(np.hypot(*(point[:2] - np.array(position[:2]))))


def test_rle_round_trip_and_boxes():
    rng = np.random.default_rng(3)
    masks = [np.zeros((5, 7), bool), np.ones((5, 7), bool), rng.random((40, 33)) > 0.7]
    blob = np.zeros((30, 50), bool)
    blob[4:9, 10:42] = True
    masks.append(blob)
    for mask in masks:
        rle = frames.encode_rle(mask)
        assert rle["size"] == list(mask.shape)
        assert (frames.decode_rle(rle) == mask).all()
        counts = frames.rle_counts(mask)
        assert (
            sum(counts) == mask.size
            and (frames.decode_rle({**rle, "counts": counts}) == mask).all()
        )
    assert frames.bbox_of(blob) == [10, 4, 32, 5]


def test_rle_is_what_pycocotools_writes():
    from pycocotools import mask as coco_mask  # the test extra's reference encoder

    mask = np.random.default_rng(4).random((60, 80)) > 0.6
    mask[:, :3] = True
    ours = frames.encode_rle(mask)
    theirs = coco_mask.encode(np.asfortranarray(mask.astype(np.uint8)))
    assert ours["counts"] == theirs["counts"].decode()
    assert coco_mask.area(ours) == mask.sum()
    assert list(coco_mask.toBbox(ours).astype(int)) == frames.bbox_of(mask)


def test_sortsim_frames_writes_a_coco_data_set(tmp_path, cell):
    out = tmp_path / "frames"
    argv = ["frames", "--perception", "truth", "--items", "10", "--duration", "4", "--seed", "2"]
    assert main([*argv, "--every", "3", "--out", str(out), "--quiet"]) == 0
    dataset = check_coco(out, cell)
    assert dataset["images"] and dataset["annotations"]
    assert sorted(os.listdir(out)) == [frames.ANNOTATIONS, frames.DEPTH, frames.IMAGES]
    assert len(os.listdir(out / frames.IMAGES)) == len(dataset["images"])
    assert {a["item_id"] for a in dataset["annotations"]} == set(range(10))
    assert dataset["info"]["config"]["seed"] == 2
    # Again into the same folder: replaced whole, nothing left beside it.
    assert main([*argv, "--every", "5", "--out", str(out), "--quiet"]) == 0
    again = check_coco(out, cell)
    assert len(os.listdir(out / frames.IMAGES)) == len(again["images"]) < len(dataset["images"])
    assert os.listdir(tmp_path) == ["frames"]


def test_bad_outputs_are_refused_before_any_work(tmp_path, capsys):
    argv = ["frames", "--perception", "truth", "--items", "3", "--quiet", "--out"]
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    assert main([*argv, str(a_file)]) == 2
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    assert main([*argv, str(other)]) == 2
    assert os.listdir(other) == ["notes.txt"]
    assert main([*argv, str(tmp_path / "new"), "--every", "0"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 3 and all(line.startswith("sortsim frames: ") for line in lines)
    assert all("--out" in line for line in lines[:2]) and "--every" in lines[2]
    assert sorted(os.listdir(tmp_path)) == ["a_file", "other"]


def test_a_busy_belt_frame_holds_tens_of_item_masks(tmp_path):
    busy = config.load(None, seed=21, items=300, duration_s=90.0, perception="truth")
    cell = config_cell(busy)  # a pool for 300 items in 90 s
    recorder = frames.FrameRecorder(tmp_path, cell, busy, every=4)
    try:
        with Episode(busy, cell) as episode:
            episode.every(busy.observation_period_s, recorder)
            episode.reset()
            while episode.data.time < 15.0 and episode.step_until_decision():
                episode.apply(episode.choose())
        dataset = recorder.dataset()
    finally:
        recorder.close()
    (tmp_path / frames.ANNOTATIONS).write_text(json.dumps(dataset), encoding="utf-8")
    check_coco(tmp_path, cell)
    per_image = np.bincount([a["image_id"] for a in dataset["annotations"]])
    assert per_image.max() >= 15


def test_an_item_hidden_under_a_sheet_has_no_mask(tmp_path, cell):
    cell.reset(0.185)
    names = [t.name for t in cell.catalogue.types]
    white, red = (0.93, 0.93, 0.91, 1.0), (0.8, 0.1, 0.1, 1.0)
    pool, data = cell.pool, cell.data
    pool.spawn(data, 0, names.index("paper_scrap"), X_CAMERA, 0.1, 0.0, red)
    pool.spawn(data, 1, names.index("paper_sheet_a4"), X_CAMERA, 0.1, 0.0, white, z_drop=0.002)
    pool.spawn(data, 2, names.index("can_330_standing"), X_CAMERA + 0.1, -0.2, 0.0, red)
    mujoco.mj_forward(cell.model, data)
    recorder = frames.FrameRecorder(tmp_path, cell, config.load(None, perception="truth"))
    try:
        recorder(None)
        dataset = recorder.dataset()
    finally:
        recorder.close()
    seen = {a["item_id"]: a for a in dataset["annotations"]}
    assert 0 not in seen or seen[0]["visible_fraction"] < 0.05
    assert seen[1]["visible_fraction"] > 0.95 and seen[2]["visible_fraction"] > 0.95
    (tmp_path / frames.ANNOTATIONS).write_text(json.dumps(dataset), encoding="utf-8")
    check_coco(tmp_path, cell)
