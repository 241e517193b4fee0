"""The camera's segmentation against the belt's density: detected, split, merged, missed.

Each flow runs as an episode runs it (`sortsim run --perception camera`: the same flow, cell
and item pool, the riders asleep on the belt), with a decision manager that never picks (the
robot's picks happen far downstream of the camera and only cost time here). At every
observation the camera perception's newest row of item pixels (belt coordinates, heights) is
recorded with the items' true poses; the rows are then cut into items and scored as
`sim.evaluation.segmentation_eval` does (`score_recording`), for the shipped split or any other
setting.

A missed item is `buried` when less than `VISIBLE_SHARE` (30 %) of its top area was seen at
every observation (the episode's visibility monitor, `sim.monitors.visibility`: a segmentation
render of the belt camera), else `visible`.

Three segmentations side by side (`METHODS`): the 8-connected regions (no split), the split of
before busy belts (walls and necks, regions reported only once complete in the window) and the
shipped one (`ITEM_SPLIT` with its cuts at concave notches; a growing region's items reported
as they end).

Run: `python -m sim.evaluation.segmentation_density --seeds 20 21 22 --cache runs/seg_density`
(6, 12, 18 and 24 items per metre at x1 and x1.5, 60 s flows).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from perception.items.scoring import SEGMENT_KINDS, SegmentScore, pooled_segments
from perception.items.split import SplitSettings
from sim import config as episode_config
from sim.episode.loop import Episode
from sim.episode.runner import config_cell
from sim.evaluation.segmentation_eval import (
    RecordedRow,
    Recording,
    TruePoses,
    cached_recording,
    score_recording,
    true_items,
)
from sim.flow.catalogue import load_catalogue
from sim.flow.config import BELT_HALF_WIDTH, X_CAMERA
from sim.flow.ground_truth import yaw_from_xmat
from sim.monitors.visibility import VISIBLE_SHARE
from sim.sensing.perception import ITEM_SPLIT
from sim.sensing.truth import ON_BELT_TOL_M

DENSITIES = (6.0, 12.0, 18.0, 24.0)
"""Items per metre of belt of the table's flows."""
SPEED_FACTORS = (1.0, 1.5)
DURATION_S = 60.0
METHODS = (
    ("8-connected", None, False),
    ("walls+necks (before)", replace(ITEM_SPLIT, concave_ratio=0.0), False),
    ("shipped", ITEM_SPLIT, True),
)
"""The segmentations of the table: (name, split settings, a growing region's items reported
as they end)."""


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
    assert episode.parts is not None  # built by reset
    held = set(int(s) for s in episode.parts.held())
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
        assert episode.parts is not None
        types = episode.parts.flow.item_types(cell.catalogue)
        speed = episode.speed
        visible = dict(episode.metrics.best_visible or {})
    return Recording(
        float(speed_factor), int(seed), speed, rows, time.process_time() - start, types, visible
    )


def load_or_record(
    cache: Path | None, density: float, speed_factor: float, seed: int, duration_s: float
) -> Recording:
    """A recording, from `cache` (a directory) when it holds it, else recorded (and stored)."""
    name = f"density{density:g}-x{speed_factor:g}-seed{seed}-{duration_s:g}s.pkl"
    path = None if cache is None else cache / name
    return cached_recording(path, lambda: record(density, speed_factor, seed, duration_s))


def buried_missed(recording: Recording, score: SegmentScore) -> int | None:
    """How many of the score's missed items were buried (`VISIBLE_SHARE`); None when the
    recording holds no visible fractions."""
    if recording.visible is None:
        return None
    assert recording.types is not None  # recorded in an episode, like `visible`
    ids = true_items(recording, recording.types)
    missed = ids[score.kinds == SEGMENT_KINDS.index("missed")]
    return int(sum(1 for i in missed if recording.visible.get(int(i), 0.0) < VISIBLE_SHARE))


LABEL = 28


def header() -> str:
    """The table's column titles."""
    kinds = "".join(f"{k + ' %':>11}" for k in SEGMENT_KINDS)
    return (
        f"{'belt, items/m, split':<{LABEL}}{'items':>6}{kinds}{'buried':>8}{'visible':>8}"
        f"{'median mm':>10}{'p95 mm':>8}"
    )


def line(label: str, score: SegmentScore, buried: int | None) -> str:
    """One line of the table: shares of the true items [%], the missed items buried and
    visible (counts; "-" unknown), the centroid error of the detected items [mm]."""
    shares = "".join(f"{100 * score.share(k):11.1f}" for k in SEGMENT_KINDS)
    p95 = float(np.percentile(score.errors_mm, 95)) if score.errors_mm.size else float("nan")
    if buried is None:
        split_missed = f"{'-':>8}{'-':>8}"
    else:
        split_missed = f"{buried:8d}{score.count('missed') - buried:8d}"
    return (
        f"{label:<{LABEL}}{score.n_true:6d}{shares}{split_missed}{score.median_mm:10.1f}{p95:8.1f}"
    )


def table(
    seeds: list[int],
    densities: tuple[float, ...] = DENSITIES,
    speed_factors: tuple[float, ...] = SPEED_FACTORS,
    methods: tuple[tuple[str, SplitSettings | None, bool], ...] = METHODS,
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
            scores: dict[str, list] = {name: [] for name, _, _ in methods}
            buried: dict[str, int | None] = dict.fromkeys(scores, 0)
            for seed in seeds:
                recording = load_or_record(cache, density, factor, seed, duration_s)
                for name, split, early in methods:
                    score = score_recording(recording, split, catalogue, early)
                    scores[name].append(score)
                    more = buried_missed(recording, score)
                    before = buried[name]
                    buried[name] = None if more is None or before is None else (before + more)
            for name, _, _ in methods:
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
    parser.add_argument("--shipped-only", action="store_true", help="the shipped split alone")
    args = parser.parse_args(argv)
    methods = METHODS[-1:] if args.shipped_only else METHODS
    print(f"shipped split: {ITEM_SPLIT}; seeds {args.seeds}; {args.duration:g} s flows")
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
