"""Labelled items of the camera perception, and a catalogue's item classifier table from them.

A flow rides the belt in physics (`sim.sensing.flow_replay.FlowReplay`, robot at home) past the
episode's own camera perception (`sim.sensing.perception.CameraPerception`: rendered frame,
noisy stereo depth, pipeline, stripe HMMs, segmentation). Every item it reports is labelled
with the true item nearest its centroid at that instant (within `MATCH_M`; reports farther
from every true item, e.g. two items merged into one, are kept with class 0 and left out of
training and scores). Per item: the features, the HMMs' posterior, the true class and type.

A catalogue other than the default has no shipped training table: `prepare_classifier`, called
where the episode's camera perception is built (`sim.episode.builder.perception`), records it
once (minutes of CPU the first time) into the user's cache folder. No command has to remember
it. The recording is done by one process at a time (an exclusive `fcntl.flock` on a hidden lock
file beside the table): a sweep's workers that want the same table wait for the first one and
then read its file, which is written to a temporary and renamed over its name.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from perception.items.features import N_FEATURES
from sim.cell.depth_noise import ZED_CLASS, StereoDepthNoise
from sim.flow.catalogue import load_catalogue
from sim.flow.config import FlowConfig
from sim.flow.ground_truth import flow_rows
from sim.flow.limits import LINE_MAX_ITEMS_PER_METRE
from sim.paths import temporary_path
from sim.sensing.flow_replay import FlowReplay
from sim.sensing.item_classifier import (
    CUSTOM_SPEED_FACTORS,
    CUSTOM_TRAIN_SEEDS,
    catalogue_table,
    is_default_catalogue,
)
from sim.sensing.perception import WINDOW_ROWS

log = logging.getLogger(__name__)
MATCH_M = 0.03
"""A report is labelled with the nearest true item within this distance of its centroid [m]."""


def record(
    speed_factor: float,
    seed: int,
    n_items: int = 100,
    duration_s: float = 90.0,
    depth_noise: StereoDepthNoise | None = ZED_CLASS,
    catalogue=None,
    mix: dict | None = None,
) -> dict:
    """Runs one flow past the camera perception; returns its labelled items (arrays).

    `catalogue` (the default one when None) and its class `mix` (`FlowConfig`'s class_priors,
    transitions, stripe_priors) set what the flow carries."""
    start = time.process_time()
    catalogue = load_catalogue() if catalogue is None else catalogue
    n_materials = catalogue.materials.count
    config = FlowConfig(
        n_items=n_items,
        duration_s=duration_s,
        speed_factor=speed_factor,
        seed=seed,
        n_materials=n_materials,
        max_items_per_metre=LINE_MAX_ITEMS_PER_METRE,  # a line's busy belts too
        **(mix or {}),
    )
    replay = FlowReplay.start(config, catalogue)
    pool, data = replay.pool, replay.data
    perception = replay.camera_perception(depth_noise, mix)
    keys = ("features", "hmm", "hmm_prior", "class_id", "type", "dist")
    rows: dict[str, list] = {k: [] for k in keys}
    try:
        for _ in replay.rows(flow_rows(replay.flow, catalogue) + WINDOW_ROWS):
            perception.observe(float(data.time))
            if not perception.reported:
                continue
            slots = pool.active_slots()
            xy = replay.items.positions(slots)[:, :2]
            for item in perception.reported:
                det = item.detection
                d = np.hypot(xy[:, 0] - det.x, xy[:, 1] - det.y) if len(slots) else np.zeros(0)
                k = int(np.argmin(d)) if len(d) else -1
                near = k >= 0 and d[k] <= MATCH_M
                item_id = int(pool.item_ids[slots[k]]) if near else -1
                rows["features"].append(item.features)
                rows["hmm"].append(item.hmm_probs)
                rows["hmm_prior"].append(item.hmm_prior)
                rows["class_id"].append(int(replay.flow.class_id[item_id]) if near else 0)
                rows["type"].append(int(pool.type_index[slots[k]]) if near else -1)
                rows["dist"].append(float(d[k]) if k >= 0 else np.inf)
    finally:
        perception.close()
    n = len(rows["class_id"])
    return {
        "features": np.array(rows["features"], dtype=np.float64).reshape(n, N_FEATURES),
        "hmm": np.array(rows["hmm"], dtype=np.float64).reshape(n, n_materials),
        "hmm_prior": np.array(rows["hmm_prior"], dtype=np.float64).reshape(n, n_materials),
        "class_id": np.array(rows["class_id"], dtype=np.int64),
        "type_index": np.array(rows["type"], dtype=np.int64),
        "dist_m": np.array(rows["dist"], dtype=np.float64),
        "seed": np.full(n, seed, dtype=np.int64),
        "speed_factor": np.full(n, speed_factor, dtype=np.float64),
        "cpu_s": np.array(time.process_time() - start),
    }


def save_arrays(path: Path, arrays: dict) -> None:
    """Write `arrays` to `path` (.npz, compressed) through a temporary renamed over it."""
    tmp = temporary_path(path, ".npz")
    try:
        np.savez_compressed(tmp, **arrays)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def load_or_record(
    cache: Path,
    speed_factor: float,
    seed: int,
    catalogue=None,
    mix: dict | None = None,
    n_items: int = 100,
) -> dict:
    """One flow's labelled items, from `cache` when there, else recorded and stored."""
    more = "" if n_items == 100 else f"-{n_items}items"
    path = cache / f"items-x{speed_factor:g}-seed{seed}{more}.npz"
    if path.exists():
        with np.load(path) as f:
            return {k: f[k] for k in f.files}
    out = record(speed_factor, seed, n_items, catalogue=catalogue, mix=mix)
    cache.mkdir(parents=True, exist_ok=True)
    save_arrays(path, out)
    return out


def gather(
    cache: Path,
    seeds,
    speed_factors,
    catalogue=None,
    mix: dict | None = None,
    items: tuple[int, ...] = (100,),
) -> dict:
    """The labelled items of every (seed, speed factor, items per flow), concatenated."""
    parts = [
        load_or_record(cache, f, s, catalogue, mix, n)
        for s in seeds
        for f in speed_factors
        for n in items
    ]
    keys = [k for k in parts[0] if k != "cpu_s" and all(k in p for p in parts)]
    return {k: np.concatenate([p[k] for p in parts]) for k in keys}


@contextlib.contextmanager
def exclusive(path: Path) -> Iterator[None]:
    """Held by one process at a time: a blocking `flock` on the hidden `.<name>.lock` beside
    `path` (kept there; the kernel lets the lock go when its process ends, however it ends)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path.with_name(f".{path.name}.lock"), os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def write_once(path: Path, write: Callable[[Path], None]) -> bool:
    """Call `write(path)` unless `path` exists, in one process at a time: a process that waited
    for another's writing finds the file and writes nothing. Returns whether it wrote."""
    if path.exists():
        return False
    with exclusive(path):
        if path.exists():
            return False
        write(path)
        return True


def _record_table(path: Path, catalogue, mix: dict | None) -> None:
    """Record the training flows of `catalogue` and keep their labelled items at `path`."""
    flows = len(CUSTOM_TRAIN_SEEDS) * len(CUSTOM_SPEED_FACTORS)
    log.info("recording the item classifier's %d training flows for this catalogue (once)", flows)
    cache = path.parent / "item_features" / path.stem.removeprefix("item_features-")
    table = gather(cache, CUSTOM_TRAIN_SEEDS, CUSTOM_SPEED_FACTORS, catalogue, mix)
    keep = table["class_id"] > 0
    save_arrays(path, {k: v[keep] for k, v in table.items()})


def ensure_catalogue_table(catalogue, mix: dict | None = None) -> Path:
    """The item classifier's training table of a catalogue other than the default (and its
    class `mix`): recorded once from `CUSTOM_TRAIN_SEEDS` at `CUSTOM_SPEED_FACTORS` through the
    camera perception and kept at `sim.sensing.item_classifier.catalogue_table`."""
    path = catalogue_table(catalogue, mix)
    write_once(path, lambda p: _record_table(p, catalogue, mix))
    return path


_PREPARED: set[tuple[str, str]] = set()
"""(catalogue digest, mix) of the tables this process has made sure of."""


def prepare_classifier(classifier: str, catalogue, mix: dict | None = None) -> None:
    """Before a camera perception of `catalogue` (and its class `mix`) is built: with the item
    classifier (`classifier` not "hmm") and a catalogue other than the default, its training
    table recorded once (`ensure_catalogue_table`). Checked once a process."""
    if classifier == "hmm":
        return
    key = (catalogue.digest, repr(sorted((mix or {}).items())))
    if key in _PREPARED:
        return
    if not is_default_catalogue(catalogue):
        ensure_catalogue_table(catalogue, mix)
    _PREPARED.add(key)
