"""Labelled items of the camera: the item classifier's training table and its item-level scores.

A flow rides the belt in physics (`sim.evaluation.flow_replay.FlowReplay`, robot at home) past
the episode's own camera perception (`sim.sensing.perception.CameraPerception`: rendered frame,
noisy stereo depth, pipeline, stripe HMMs, segmentation). Every item it reports is labelled
with the true item nearest its centroid at that instant (within `MATCH_M`; reports farther
from every true item, e.g. two items merged into one, are kept with class 0 and left out of
training and scores). Per item: the features, the HMMs' posterior, the true class and type.

    python -m sim.evaluation.item_features record --out sim/data/item_features.npz
    python -m sim.evaluation.item_features evaluate --seeds 0 1 2 3 4

`record` writes the training table the shipped classifier is fitted from (training seeds
100-115 at x1, x1.2, x1.5, flows of 100 and of 200 items in 90 s: `TRAIN_SEEDS`,
`SPEED_FACTORS`, `TRAIN_ITEMS`); `evaluate` records held-out flows and prints, per class and
overall, the accuracy of the `hmm`, `features` and `fused` modes. Recordings are cached per
flow in `--cache` (default `item_features/<digest of the camera and perception code>` in the
user's cache folder, `sim.user_cache`, so a change of that code records afresh), named after
the flow's settings.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from pathlib import Path

import numpy as np

from perception.codes import CLASS_NAMES
from perception.items.classifier import MATERIAL_IDS, ItemClassifier, fuse
from perception.items.features import N_FEATURES
from sim.cell.depth_noise import ZED_CLASS, StereoDepthNoise
from sim.evaluation.flow_replay import FlowReplay
from sim.flow.catalogue import load_catalogue
from sim.flow.config import FlowConfig
from sim.flow.ground_truth import flow_rows
from sim.flow.limits import LINE_MAX_ITEMS_PER_METRE
from sim.sensing.item_classifier import (
    CUSTOM_SPEED_FACTORS,
    CUSTOM_TRAIN_SEEDS,
    FIT_SEED,
    TRAINING_TABLE,
    catalogue_table,
    is_default_catalogue,
    load_table,
    recording_code_digest,
)
from sim.sensing.perception import WINDOW_ROWS
from sim.user_cache import cache_dir

log = logging.getLogger(__name__)
MATCH_M = 0.03
"""A report is labelled with the nearest true item within this distance of its centroid [m]."""
CACHE_FOLDER = "item_features"
"""`--cache`'s default is this folder of the user's cache folder, then one named by
`recording_code_digest()` (read when the command runs, not when an episode's command imports
this module for `prepare_camera`)."""
TRAIN_SEEDS = tuple(range(100, 116))
SPEED_FACTORS = (1.0, 1.2, 1.5)
TRAIN_ITEMS = (100, 200)
"""Items of a 90 s training flow: the headline's 6 per metre and the 12 of tables 4.5/4.6 (busy
belts: items touching, their footprints cut apart)."""


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
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.npz")
    np.savez_compressed(tmp, **out)
    tmp.replace(path)
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


def ensure_catalogue_table(catalogue, mix: dict | None = None) -> Path:
    """The item classifier's training table of a catalogue other than the default (and its
    class `mix`): recorded once from `CUSTOM_TRAIN_SEEDS` at `CUSTOM_SPEED_FACTORS` through the
    camera perception and kept at `sim.sensing.item_classifier.catalogue_table`."""
    path = catalogue_table(catalogue, mix)
    if path.exists():
        return path
    flows = len(CUSTOM_TRAIN_SEEDS) * len(CUSTOM_SPEED_FACTORS)
    log.info("recording the item classifier's %d training flows for this catalogue (once)", flows)
    cache = path.parent / "item_features" / path.stem.removeprefix("item_features-")
    table = gather(cache, CUSTOM_TRAIN_SEEDS, CUSTOM_SPEED_FACTORS, catalogue, mix)
    keep = table["class_id"] > 0
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.npz")
    np.savez_compressed(tmp, **{k: v[keep] for k, v in table.items()})
    os.replace(tmp, path)
    return path


def prepare_camera(*configs) -> None:
    """Before camera episodes (`EpisodeConfig`s): the item classifier's training table of each
    other catalogue than the default (and its mix), recorded once (minutes of CPU the first
    time). Every command that runs camera episodes calls this, and only this: recording runs
    episodes, so the episode's builder, below this room, cannot record on demand; it refuses
    an unrecorded catalogue in one line instead."""
    seen = set()
    for config in configs:
        if config.perception != "camera" or config.classifier == "hmm":
            continue
        if is_default_catalogue(config.item_catalogue):
            continue
        key = (config.catalogue, repr(config.mix_kwargs))
        if key not in seen:
            seen.add(key)
            ensure_catalogue_table(config.item_catalogue, config.mix_kwargs)


def accuracy_table(table: dict, classifier: ItemClassifier) -> list[str]:
    """Lines of the item-level table: accuracy per class of each mode on labelled items."""
    labelled = table["class_id"] > 0
    truth = table["class_id"][labelled]
    hmm = table["hmm"][labelled]
    clf = classifier.probabilities(table["features"][labelled])
    names = [CLASS_NAMES[c - 1] for c in MATERIAL_IDS]
    lines = [
        "| mode | " + " | ".join(names) + " | all |",
        "|---|" + "---|" * (len(names) + 1),
    ]
    prior = table["hmm_prior"][labelled]
    rows = (
        ("hmm (the thesis's: the HMMs' posterior)", hmm),
        ("features", clf),
        ("fused (features x the HMMs' prediction)", fuse(clf, classifier.train_prior, prior)),
        ("features x the HMMs' posterior", fuse(clf, classifier.train_prior, hmm)),
        ("the HMMs' prediction alone", prior),
    )
    for label, probs in rows:
        guess = np.asarray(MATERIAL_IDS)[np.argmax(probs, axis=1)]
        cells = []
        for c in MATERIAL_IDS:
            mine = truth == c
            cells.append(f"{np.mean(guess[mine] == c):.3f} (n={int(mine.sum())})")
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {np.mean(guess == truth):.3f} |")
    lines.append(errors_by_type(table, labelled, fuse(clf, classifier.train_prior, prior)))
    unmatched = int(np.sum(~labelled))
    lines.append(f"reports matched to no true item within {MATCH_M * 1000:.0f} mm: {unmatched}")
    return lines


def errors_by_type(
    table: dict, labelled: np.ndarray, probs: np.ndarray, most: int = 6, mode: str = "fused mode's"
) -> str:
    """One line: the item types `probs` (of the `labelled` items) err on most (wrong of all, and
    as what), named by the default catalogue (`table["type_index"]` indexes its types)."""
    names = [t.name for t in load_catalogue().types]
    types = table["type_index"][labelled]
    guess = np.asarray(MATERIAL_IDS)[np.argmax(probs, axis=1)]
    wrong = guess != table["class_id"][labelled]
    counts = [(int(np.sum(wrong & (types == k))), k) for k in np.unique(types)]
    counts.sort(reverse=True)
    parts = []
    for n_wrong, k in counts[:most]:
        if n_wrong == 0:
            break
        as_what = np.bincount(guess[wrong & (types == k)], minlength=max(MATERIAL_IDS) + 1)
        taken = ", ".join(f"{CLASS_NAMES[c - 1]} {as_what[c]}" for c in MATERIAL_IDS if as_what[c])
        parts.append(f"{names[k]} {n_wrong} of {int(np.sum(types == k))} ({taken})")
    total = f"{int(wrong.sum())} of {int(labelled.sum())}"
    return f"{mode} errors ({total}), by item type: " + ("; ".join(parts) or "none")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim.evaluation.item_features")
    parser.add_argument("action", choices=("record", "evaluate"))
    parser.add_argument("--seeds", type=int, nargs="+", default=None)
    parser.add_argument("--speed-factors", type=float, nargs="+", default=list(SPEED_FACTORS))
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=TRAINING_TABLE)
    parser.add_argument("--table", type=Path, default=TRAINING_TABLE, help="training table")
    parser.add_argument(
        "--items", type=int, nargs="+", default=None, help="items of a 90 s flow (each count)"
    )
    args = parser.parse_args(argv)
    args.cache = args.cache or cache_dir() / CACHE_FOLDER / recording_code_digest()
    items = tuple(args.items or ((100,) if args.action == "evaluate" else TRAIN_ITEMS))
    if args.action == "record":
        seeds = args.seeds or list(TRAIN_SEEDS)
        table = gather(args.cache, seeds, args.speed_factors, items=items)
        keep = table["class_id"] > 0
        out = {k: v[keep] for k, v in table.items()}
        tmp = args.out.with_name(f".{args.out.stem}.tmp.npz")
        np.savez_compressed(tmp, **out)
        tmp.replace(args.out)
        counts = {CLASS_NAMES[c - 1]: int(np.sum(out["class_id"] == c)) for c in MATERIAL_IDS}
        print(f"wrote {args.out}: {int(keep.sum())} labelled items {counts}", file=sys.stderr)
        return 0
    seeds = args.seeds or [0, 1, 2, 3, 4]
    train = load_table(args.table)
    overlap = set(np.unique(train["seed"]).tolist()) & set(seeds)
    if overlap:
        print(f"seeds: held-out seeds only (these trained the classifier: {sorted(overlap)})")
        return 2
    classifier = ItemClassifier(train["features"], train["class_id"], seed=FIT_SEED)
    table = gather(args.cache, seeds, args.speed_factors, items=items)
    trained = sorted(np.unique(train["seed"]).tolist())
    n_train = len(train["class_id"])
    print(
        f"held-out seeds {seeds} at x{args.speed_factors}, {list(items)} items in 90 s; trained "
        f"on seeds {trained} ({n_train})"
    )
    print("\n".join(accuracy_table(table, classifier)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
