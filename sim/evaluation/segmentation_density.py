"""The camera's segmentation against the belt's density: detected, split, merged, missed.

Each flow runs as an episode runs it (`sortsim run --perception camera`: the same flow, cell
and item pool, the riders asleep on the belt), with a decision manager that never picks (the
robot's picks happen far downstream of the camera and only cost time here). At every
observation the camera perception's newest row of item pixels (belt coordinates, heights) is
recorded with the items' true poses; the rows are then cut into items and scored as
`sim.evaluation.segmentation_eval` does (`score_recording`), for the shipped split or any other
setting.

A missed item is `buried` when at every observation it was wholly past the camera line, less
than `BURIED_SHARE` of its footprint was uncovered by the items lying higher (footprints seen
from straight above: the camera's slant is left out), else `visible`.

Run: `python -m sim.evaluation.segmentation_density --seeds 20 21 22 --cache runs/seg_density`
(6, 12, 18 and 24 items per metre at x1 and x1.5, 60 s flows).
"""

from __future__ import annotations

import argparse
import math
import pickle
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from perception.items.scoring import SEGMENT_KINDS, SegmentScore, pooled_segments
from perception.items.split import SplitSettings
from sim.episode import config as episode_config
from sim.episode.loop import Episode
from sim.episode.runner import config_cell
from sim.evaluation.segmentation_eval import (
    RecordedRow,
    Recording,
    TruePoses,
    from_plain,
    score_recording,
    true_items,
)
from sim.flow.catalogue import Catalogue, ItemType, load_catalogue
from sim.flow.config import BELT_HALF_WIDTH, X_CAMERA
from sim.flow.footprint_polygons import contains, to_body
from sim.flow.ground_truth import yaw_from_xmat
from sim.sensing.perception import ITEM_SPLIT, ON_BELT_TOL_M

DENSITIES = (6.0, 12.0, 18.0, 24.0)
"""Items per metre of belt of the table's flows."""
SPEED_FACTORS = (1.0, 1.5)
DURATION_S = 60.0
BURIED_SHARE = 0.3
"""A missed item with less than this share of its footprint uncovered at every observation is
buried."""
_SAMPLE_M = 0.004
"""Pitch of the points an item's footprint is sampled on for its uncovered share [m]."""


class _NeverPick:
    """A decision manager that leaves every item on the belt."""

    name = "never"

    def reset(self) -> None:
        """Nothing kept."""

    def choose(self, items, robot, context):
        """No pick."""
        return None


def n_items(density: float, speed_factor: float, duration_s: float = DURATION_S) -> int:
    """Items of a flow of `density` items per metre at `speed_factor` over `duration_s`."""
    config = episode_config.load(None, speed_factor=speed_factor)
    return int(round(density * config.belt_speed_mps * duration_s))


def _truth(episode: Episode) -> TruePoses:
    """The true poses of the items near the camera (resting on the belt or not)."""
    items, pool = episode.cell.items, episode.cell.pool
    held = set(int(s) for s in episode.held())
    slots = np.array([int(s) for s in items.active_slots() if int(s) not in held], np.int64)
    if slots.size == 0:
        empty = np.zeros(0)
        return TruePoses(np.zeros(0, np.int64), empty, empty, empty, np.zeros(0, np.int64),
                         np.zeros(0, bool), empty)  # fmt: skip
    xyz = items.positions(slots)
    near = (xyz[:, 0] > X_CAMERA - 0.4) & (xyz[:, 0] < X_CAMERA + 1.3)
    slots, xyz = slots[near], xyz[near]
    rest = np.array([pool.item_type(int(s)).rest_height for s in slots])
    on_belt = (xyz[:, 2] > -0.05) & (xyz[:, 2] < rest + ON_BELT_TOL_M)
    return TruePoses(
        pool.item_ids[slots].copy(),
        xyz[:, 0].copy(),
        xyz[:, 1].copy(),
        yaw_from_xmat(items.orientations(slots)) if slots.size else np.zeros(0),
        pool.type_index[slots].copy(),
        on_belt & (np.abs(xyz[:, 1]) <= BELT_HALF_WIDTH),
        xyz[:, 2].copy(),
    )


def record(
    density: float, speed_factor: float, seed: int, duration_s: float = DURATION_S
) -> Recording:
    """Runs the flow as a camera episode and records the perception's rows with the truth."""
    start = time.process_time()
    config = episode_config.load(
        None,
        perception="camera",
        classifier="hmm",
        items=n_items(density, speed_factor, duration_s),
        duration_s=duration_s,
        seed=seed,
        speed_factor=speed_factor,
    )
    rows: list[RecordedRow] = []

    def watch(episode: Episode) -> None:
        perception = episode.perception
        rows.append(
            RecordedRow(
                float(episode.data.time),
                list(perception.pixels[-1]),
                list(perception.pixel_y[-1]),
                list(perception.pixel_height[-1]),
                _truth(episode),
            )
        )

    cell = config_cell(config)
    with Episode(config, cell, planner=_NeverPick()) as episode:
        episode.reset()
        observe = episode.perception.observe

        def observed(t: float):
            detections = observe(t)
            watch(episode)
            return detections

        episode.perception.observe = observed
        episode.run()
        types = episode.flow.item_types(cell.catalogue)
        speed = episode.speed
    return Recording(
        float(speed_factor), int(seed), speed, rows, time.process_time() - start, types
    )


def load_or_record(
    cache: Path | None, density: float, speed_factor: float, seed: int, duration_s: float
) -> Recording:
    """A recording, from `cache` (a directory) when it holds it, else recorded (and stored)."""
    name = f"density{density:g}-x{speed_factor:g}-seed{seed}-{duration_s:g}s.pkl"
    path = None if cache is None else cache / name
    if path is not None and path.exists():
        with path.open("rb") as f:
            return from_plain(pickle.load(f))
    recording = record(density, speed_factor, seed, duration_s)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        with tmp.open("wb") as f:
            pickle.dump(asdict(recording), f)
        tmp.replace(path)
    return recording


def _footprint_points(item_type: ItemType) -> tuple[np.ndarray, np.ndarray]:
    """Body-frame points [m] sampling an item's footprint on a `_SAMPLE_M` grid."""
    r = math.hypot(item_type.half_length, item_type.half_width)
    g = np.arange(-r, r + _SAMPLE_M, _SAMPLE_M)
    lx, ly = (a.ravel() for a in np.meshgrid(g, g))
    inside = contains(item_type, lx, ly)
    return lx[inside], ly[inside]


def uncovered_shares(recording: Recording, catalogue: Catalogue) -> dict[int, float]:
    """Per true item, the largest share of its footprint that no higher item covered, over the
    observations at which it lay wholly past the camera line on the belt."""
    types = recording.types
    points = {}
    best: dict[int, float] = {}
    for row in recording.rows:
        truth = row.truth
        if truth.z is None:
            continue
        for n in np.flatnonzero(truth.on_belt):
            item_id = int(truth.item_id[n])
            item_type = types[item_id]
            if truth.x[n] - math.hypot(item_type.half_length, item_type.half_width) <= X_CAMERA:
                continue
            if item_id not in points:
                points[item_id] = _footprint_points(item_type)
            lx, ly = points[item_id]
            c, s = math.cos(truth.yaw[n]), math.sin(truth.yaw[n])
            px, py = truth.x[n] + c * lx - s * ly, truth.y[n] + s * lx + c * ly
            covered = np.zeros(px.size, bool)
            for m in np.flatnonzero(truth.on_belt & (truth.z > truth.z[n])):
                other = types[int(truth.item_id[m])]
                reach = math.hypot(item_type.half_length, item_type.half_width) + math.hypot(
                    other.half_length, other.half_width
                )
                if math.hypot(truth.x[m] - truth.x[n], truth.y[m] - truth.y[n]) > reach:
                    continue
                ox, oy = to_body(px, py, truth.x[m], truth.y[m], truth.yaw[m])
                covered |= contains(other, ox, oy)
            share = 1.0 - covered.mean() if px.size else 1.0
            best[item_id] = max(best.get(item_id, 0.0), float(share))
    return best


def buried_missed(recording: Recording, score: SegmentScore, catalogue: Catalogue) -> int:
    """How many of the score's missed items were buried (`BURIED_SHARE`)."""
    ids = true_items(recording, recording.types)
    shares = uncovered_shares(recording, catalogue)
    missed = ids[score.kinds == SEGMENT_KINDS.index("missed")]
    return int(sum(1 for i in missed if shares.get(int(i), 1.0) < BURIED_SHARE))


LABEL = 28


def header() -> str:
    """The table's column titles."""
    kinds = "".join(f"{k + ' %':>11}" for k in SEGMENT_KINDS)
    return (
        f"{'belt, items/m, split':<{LABEL}}{'items':>6}{kinds}{'buried':>8}{'visible':>8}"
        f"{'median mm':>10}{'p95 mm':>8}"
    )


def line(label: str, score: SegmentScore, buried: int) -> str:
    """One line of the table: shares of the true items [%], the missed items buried and
    visible (counts), the centroid error of the detected items [mm]."""
    shares = "".join(f"{100 * score.share(k):11.1f}" for k in SEGMENT_KINDS)
    p95 = float(np.percentile(score.errors_mm, 95)) if score.errors_mm.size else float("nan")
    visible = score.count("missed") - buried
    return (
        f"{label:<{LABEL}}{score.n_true:6d}{shares}{buried:8d}{visible:8d}"
        f"{score.median_mm:10.1f}{p95:8.1f}"
    )


def table(
    seeds: list[int],
    densities: tuple[float, ...] = DENSITIES,
    speed_factors: tuple[float, ...] = SPEED_FACTORS,
    methods: tuple[tuple[str, SplitSettings | None], ...] = (("split", ITEM_SPLIT),),
    cache: Path | None = None,
    duration_s: float = DURATION_S,
    out=print,
) -> dict[tuple[float, float, str], SegmentScore]:
    """Prints the table (one line per belt speed, density and method, pooled over the seeds)
    and returns the pooled scores."""
    catalogue = load_catalogue()
    out(header())
    pooled = {}
    for factor in speed_factors:
        for density in densities:
            scores: dict[str, list] = {name: [] for name, _ in methods}
            buried = dict.fromkeys(scores, 0)
            for seed in seeds:
                recording = load_or_record(cache, density, factor, seed, duration_s)
                for name, split in methods:
                    score = score_recording(recording, split, catalogue)
                    scores[name].append(score)
                    buried[name] += buried_missed(recording, score, catalogue)
            for name, _ in methods:
                score = pooled_segments(scores[name])
                pooled[(factor, density, name)] = score
                out(line(f"x{factor:g} {density:g}/m {name}", score, buried[name]))
    return pooled


def main(argv: list[str] | None = None) -> int:
    """Prints the segmentation table against the belt's density."""
    parser = argparse.ArgumentParser(
        prog="python -m sim.evaluation.segmentation_density", description=__doc__
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[20, 21, 22])
    parser.add_argument("--densities", type=float, nargs="+", default=list(DENSITIES))
    parser.add_argument("--speed-factors", type=float, nargs="+", default=list(SPEED_FACTORS))
    parser.add_argument("--duration", type=float, default=DURATION_S)
    parser.add_argument("--cache", type=Path, default=None, help="directory of recordings")
    parser.add_argument("--whole", action="store_true", help="8-connected regions as well")
    args = parser.parse_args(argv)
    methods: tuple = (("split", ITEM_SPLIT),)
    if args.whole:
        methods = (("8-connected", None), *methods)
    print(f"split: {ITEM_SPLIT}; seeds {args.seeds}; {args.duration:g} s flows")
    table(
        args.seeds,
        tuple(args.densities),
        tuple(args.speed_factors),
        methods,
        args.cache,
        args.duration,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
