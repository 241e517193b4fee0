"""The camera's items scored against the truth item by item: detected, split, merged, missed.

A flow rides the belt in physics (`sim.sensing.flow_replay.FlowReplay`, robot at home) and
once per observation period the episode's own camera perception
(`sim.sensing.perception.CameraPerception`: rendered frame and depth map, pipeline, HMMs) takes
its frame; the newest row of its window of item pixels (belt coordinates and heights) is
recorded with the items' true poses at that instant. The recorded rows then go through the
same sliding window as the perception's, cut into items by `perception.items.blobs.item_blobs`
(reported when their region is complete) either as 8-connected regions (as before
touching items were split) or with the split of `perception.items.split`. Each found item's
pixels are matched to the true footprints they fall in (`sim.flow.footprint_polygons`, grown by
`GROW_M`) and each true item that crossed the camera line on the belt is detected, split,
merged or missed (`perception.items.scoring.score_segments`); the centroid error of a detected
item is the distance from its found centroid to its true centre at the time it was reported.

Run: `python -m sim.evaluation.segmentation_eval --seeds 0 1 2 3 4` (x1, x1.2, x1.5).
"""

from __future__ import annotations

import argparse
import math
import pickle
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from perception.codes import N_STATES
from perception.items.blobs import item_blobs
from perception.items.scoring import SEGMENT_KINDS, SegmentScore, pooled_segments, score_segments
from perception.items.split import SplitSettings
from sim.flow.catalogue import Catalogue, ItemType, load_catalogue
from sim.flow.config import BELT_HALF_WIDTH, X_CAMERA, FlowConfig
from sim.flow.footprint_polygons import contains_grown, to_body
from sim.flow.generator import generate_flow
from sim.flow.ground_truth import flow_rows, yaw_from_xmat
from sim.sensing.flow_replay import FlowReplay
from sim.sensing.perception import (
    COMPLETE_ROW,
    ITEM_SPLIT,
    WINDOW_ROWS,
)
from sim.sensing.truth import ON_BELT_TOL_M
from sim.user_cache import open_own_file

GROW_M = 0.003
"""A found pixel belongs to a true item when it lies within this of its outline [m]: the
footprint raster's pixels are 2 mm, and half the 5 mm gap keeps grown outlines apart."""


@dataclass(frozen=True, eq=False)
class TruePoses:
    """The items on the belt at one instant.

    Attributes:
        item_id: Flow index of each active item.
        x, y: Centre on the belt plane [m].
        yaw: Heading of the body x axis [rad].
        type_index: Catalogue type.
        on_belt: Resting on the belt (not thrown off, not held).
        z: Height of the centre [m] (None in recordings made before it was kept).
    """

    item_id: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    type_index: np.ndarray
    on_belt: np.ndarray
    z: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class RecordedRow:
    """One observation: the window's newest row of item pixels and the truth at time `t`.

    Attributes:
        t: Time of the frame [s].
        pixel_b: Per stripe, the item pixels' belt coordinates [m].
        pixel_y: Per stripe, their lateral positions [m].
        pixel_height: Per stripe, their heights above the belt [m].
        truth: The items' true poses at `t`.
    """

    t: float
    pixel_b: list[np.ndarray]
    pixel_y: list[np.ndarray]
    pixel_height: list[np.ndarray]
    truth: TruePoses


@dataclass(frozen=True, eq=False)
class Recording:
    """The camera perception's rows of one flow (`record`).

    `types` holds the (scaled) type of every item of the flow by flow index when the flow is
    not the default one of `N_ITEMS` items in `DURATION_S` (`flow_item_types`); `visible` the
    largest visible fraction of each item's top area over the observations, by flow index,
    when the recording was made in an episode (`sim.monitors.visibility`).
    """

    speed_factor: float
    seed: int
    speed: float
    rows: list[RecordedRow]
    cpu_s: float
    types: tuple[ItemType, ...] | None = None
    visible: dict[int, float] | None = None


@dataclass(frozen=True, eq=False)
class FoundItem:
    """An item reported from the window of row `k` (at time `t` [s]): centroid and pixels [m]."""

    k: int
    t: float
    b: float
    y: float
    pixel_b: np.ndarray
    pixel_y: np.ndarray


N_ITEMS = 100
DURATION_S = 90.0


def record(
    speed_factor: float, seed: int, n_items: int = N_ITEMS, duration_s: float = DURATION_S
) -> Recording:
    """Runs a flow past the camera perception and records its rows with the truth."""
    start = time.process_time()
    catalogue = load_catalogue()
    config = FlowConfig(
        n_items=n_items, duration_s=duration_s, speed_factor=speed_factor, seed=seed
    )
    replay = FlowReplay.start(config, catalogue)
    pool, data = replay.pool, replay.data
    perception = replay.camera_perception()
    rows = []
    try:
        for _ in replay.rows(flow_rows(replay.flow, catalogue) + WINDOW_ROWS):
            t = float(data.time)
            perception.observe(t)
            slots = pool.active_slots()
            xyz = replay.items.positions(slots)
            types = pool.type_index[slots].copy()
            rest = np.array([pool.item_type(int(s)).rest_height for s in slots])
            on_belt = (xyz[:, 2] > -0.05) & (xyz[:, 2] < rest + ON_BELT_TOL_M)
            truth = TruePoses(
                pool.item_ids[slots].copy(),
                xyz[:, 0].copy(),
                xyz[:, 1].copy(),
                yaw_from_xmat(replay.items.orientations(slots)),
                types,
                on_belt & (np.abs(xyz[:, 1]) <= BELT_HALF_WIDTH),
            )
            rows.append(
                RecordedRow(
                    t,
                    list(perception.pixels[-1]),
                    list(perception.pixel_y[-1]),
                    list(perception.pixel_height[-1]),
                    truth,
                )
            )
    finally:
        perception.close()
    return Recording(
        float(speed_factor), int(seed), replay.speed, rows, time.process_time() - start
    )


def found_items(
    recording: Recording, split: SplitSettings | None, early: bool = True
) -> list[FoundItem]:
    """The items the perception reports from the recorded rows, with or without the split;
    `early` False: only the regions complete in the window (`item_blobs` without its
    reported pixels, as before busy belts)."""
    rows = recording.rows
    stripes = len(rows[0].pixel_b) if rows else 0
    empty = [np.zeros(0)] * stripes
    window_b = [empty] * WINDOW_ROWS
    window_y = [empty] * WINDOW_ROWS
    window_h = [empty] * WINDOW_ROWS
    window_done = [[np.zeros(0, bool)] * stripes] * WINDOW_ROWS
    posteriors = np.full((WINDOW_ROWS, stripes, N_STATES), 1.0 / N_STATES)
    found = []
    for k, row in enumerate(rows):
        window_b = window_b[1:] + [row.pixel_b]
        window_y = window_y[1:] + [row.pixel_y]
        window_h = window_h[1:] + [row.pixel_height]
        window_done = window_done[1:] + [[np.zeros(len(b), bool) for b in row.pixel_b]]
        blobs = item_blobs(
            window_b,
            window_y,
            posteriors,
            pixel_height=window_h,
            split=split,
            complete_row=COMPLETE_ROW,
            reported=window_done if early else None,
        )
        if not blobs:
            continue
        all_b = np.concatenate([a for r in window_b for a in r])
        all_y = np.concatenate([a for r in window_y for a in r])
        for blob in blobs:
            found.append(
                FoundItem(k, row.t, blob.b, blob.y, all_b[blob.members], all_y[blob.members])
            )
    return found


def flow_item_types(recording: Recording, catalogue: Catalogue) -> tuple[ItemType, ...]:
    """The (scaled) type of every item of the recording's flow, as dropped on the belt."""
    if recording.types is not None:
        return recording.types
    config = FlowConfig(
        n_items=N_ITEMS, duration_s=DURATION_S, speed_factor=recording.speed_factor,
        seed=recording.seed,
    )  # fmt: skip
    return generate_flow(config, catalogue).item_types(catalogue)


def true_items(recording: Recording, types: tuple[ItemType, ...]) -> np.ndarray:
    """Flow indices of the items seen resting on the belt wholly past the camera line."""
    seen = set()
    for row in recording.rows:
        truth = row.truth
        for n in np.flatnonzero(truth.on_belt):
            item_type = types[int(truth.item_id[n])]
            if truth.x[n] - math.hypot(item_type.half_length, item_type.half_width) > X_CAMERA:
                seen.add(int(truth.item_id[n]))
    return np.array(sorted(seen), dtype=np.int64)


def score_recording(
    recording: Recording, split: SplitSettings | None, catalogue: Catalogue, early: bool = True
) -> SegmentScore:
    """Detected / split / merged / missed of every true item of the recording (`early`: as
    `found_items`)."""
    types = flow_item_types(recording, catalogue)
    ids = true_items(recording, types)
    column = {int(i): c for c, i in enumerate(ids)}
    found = found_items(recording, split, early)
    overlap = np.zeros((len(found), len(ids)))
    distance = np.full((len(found), len(ids)), np.inf)
    for f, item in enumerate(found):
        truth = recording.rows[item.k].truth
        travel = X_CAMERA + recording.speed * item.t
        x, centre_x = travel - item.pixel_b, travel - item.b
        for n in np.flatnonzero(truth.on_belt):
            c = column.get(int(truth.item_id[n]))
            if c is None:
                continue
            item_type = types[int(truth.item_id[n])]
            reach = math.hypot(item_type.half_length, item_type.half_width) + GROW_M
            near = (np.abs(x - truth.x[n]) <= reach) & (np.abs(item.pixel_y - truth.y[n]) <= reach)
            if np.any(near):
                lx, ly = to_body(x[near], item.pixel_y[near], truth.x[n], truth.y[n], truth.yaw[n])
                overlap[f, c] = np.count_nonzero(contains_grown(item_type, lx, ly, GROW_M))
            distance[f, c] = math.hypot(centre_x - truth.x[n], item.y - truth.y[n])
    sizes = np.array([len(item.pixel_b) for item in found], dtype=float)
    return score_segments(overlap, sizes, distance)


def load_or_record(cache: Path | None, speed_factor: float, seed: int) -> Recording:
    """A recording, from `cache` (a directory) when it holds it, else recorded (and stored)."""
    path = None if cache is None else cache / f"segmentation-x{speed_factor:g}-seed{seed}.pkl"
    return cached_recording(path, lambda: record(speed_factor, seed))


def cached_recording(path: Path | None, make: Callable[[], Recording]) -> Recording:
    """The recording stored at `path` when there is one, else `make()`'s, stored there (written
    to a temporary file and renamed); `path` None: never stored. A stored recording is a
    pickle, loaded only from a file of this user's that no one else can write
    (`sim.user_cache.open_own_file`)."""
    if path is not None and path.exists():
        with open_own_file(path, "segmentation recording") as f:
            return from_plain(pickle.load(f))
    recording = make()
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        with tmp.open("wb") as f:
            pickle.dump(asdict(recording), f)
        tmp.replace(path)
    return recording


def from_plain(plain: dict) -> Recording:
    """A recording from its `dataclasses.asdict` form (what the cache stores: plain types, so
    the files do not depend on how this module was run)."""
    rows = [RecordedRow(**{**row, "truth": TruePoses(**row["truth"])}) for row in plain["rows"]]
    types = plain.get("types")
    if types is not None:
        types = tuple(ItemType(**t) for t in types)
    visible = plain.get("visible")
    if visible is not None:
        visible = {int(k): float(v) for k, v in visible.items()}
    return Recording(**{**plain, "rows": rows, "types": types, "visible": visible})


LABEL_WIDTH = 24


def table_header() -> str:
    """The report's column titles."""
    kinds = "".join(f"{kind + ' %':>12}" for kind in SEGMENT_KINDS)
    return f"{'speed, segmentation':<{LABEL_WIDTH}}{'items':>6}{kinds}{'spurious':>9}" + (
        f"{'median mm':>11}{'found':>7}"
    )


def table_row(label: str, score: SegmentScore) -> str:
    """One line of the report: shares of the true items [%], spurious found items, the median
    centroid error of the detected items [mm], found items."""
    shares = "".join(f"{100 * score.share(kind):12.1f}" for kind in SEGMENT_KINDS)
    return (
        f"{label:<{LABEL_WIDTH}}{score.n_true:6d}{shares}{score.spurious:9d}"
        f"{score.median_mm:11.1f}{score.n_found:7d}"
    )


def main(argv: list[str] | None = None) -> int:
    """Prints the before/after table of each speed factor, pooled over the seeds."""
    parser = argparse.ArgumentParser(
        prog="python -m sim.evaluation.segmentation_eval", description=__doc__
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--speed-factors", type=float, nargs="+", default=[1.0, 1.2, 1.5])
    parser.add_argument("--cache", type=Path, default=None, help="directory of recordings")
    parser.add_argument("--raster-mm", type=float, default=1000 * ITEM_SPLIT.raster_m)
    parser.add_argument("--step-mm", type=float, default=1000 * ITEM_SPLIT.step_m)
    parser.add_argument("--neck-ratio", type=float, default=ITEM_SPLIT.neck_ratio)
    parser.add_argument("--min-core-mm", type=float, default=1000 * ITEM_SPLIT.min_core_m)
    parser.add_argument("--median-cells", type=int, default=ITEM_SPLIT.height_median_cells)
    parser.add_argument("--per-seed", action="store_true", help="a line per seed as well")
    args = parser.parse_args(argv)
    settings = replace(
        ITEM_SPLIT,
        raster_m=args.raster_mm / 1000,
        step_m=args.step_mm / 1000,
        neck_ratio=args.neck_ratio,
        min_core_m=args.min_core_mm / 1000,
        height_median_cells=args.median_cells,
    )
    catalogue = load_catalogue()
    methods = (("8-connected", None), ("split", settings))
    print(f"split: {settings}; seeds {args.seeds}")
    print(table_header())
    for factor in args.speed_factors:
        scores: dict[str, list[SegmentScore]] = {name: [] for name, _ in methods}
        for seed in args.seeds:
            recording = load_or_record(args.cache, factor, seed)
            for name, split in methods:
                score = score_recording(recording, split, catalogue)
                scores[name].append(score)
                if args.per_seed:
                    print(table_row(f"  seed {seed} {name}", score), flush=True)
        for name, _ in methods:
            print(table_row(f"x{factor:g} {name}", pooled_segments(scores[name])), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
