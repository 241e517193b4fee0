"""Where the camera path loses the items it never detects: one episode, stage by stage.

A camera episode runs as `sortsim run` runs it, watched at each observation (the
perception's window, the blobs it cut, the detections it reported, what the tracker did with
each, and which item the attribution booked a new track to) with the items' true poses at
that instant. Afterwards every item that entered and left the belt gets the first stage that
lost it:

- `not seen`: no item pixel of any row fell on its footprint (buried under another item, or
  lost in the colour and depth thresholds);
- `not reported`: pixels of it were seen but no reported blob holds any (a region under the
  smallest blob, or never complete in the window);
- `merged`: the blob that holds most of its pixels is mostly another item's (one blob, one
  track, for two items);
- `tracker`: its own blob's detection joined an existing track (the tracker's match radius
  and class gate);
- `attribution`: its own blob's detection made a new track that the bookkeeping booked to
  another item, or to none;
- `detected`: a track was booked to it.

A pixel lying on the footprints of several items is the highest item's (the item whose centre
stands highest; items lie on each other on busy belts). `visible` is the share of an item's
footprint area that the rows' pixels covered (2 mm raster), a proxy for how much of its top
the camera saw.

Run: `python -m sim.evaluation.detection_audit --items 200 --seeds 20 21` (x1, 90 s).
"""

from __future__ import annotations

import argparse
import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

import sim.episode.item_checks as item_checks_module
import sim.sensing.perception as perception_module
from sim import config as episode_config
from sim.episode.loop import Episode
from sim.episode.runner import config_cell
from sim.flow.config import BELT_HALF_WIDTH, X_CAMERA
from sim.flow.footprint_polygons import contains_grown, to_body
from sim.flow.ground_truth import yaw_from_xmat

GROW_M = 0.003
"""A pixel within this of an item's outline lies on it [m] (as `segmentation_eval`)."""
PIXEL_M = 0.002
"""The footprint raster's pitch [m]: a pixel covers PIXEL_M**2 of the belt."""
STAGES = ("detected", "not seen", "not reported", "merged", "tracker", "attribution")


@dataclass
class Poses:
    """The items on the belt near the camera at one observation."""

    item_id: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    yaw: np.ndarray
    types: list


@dataclass
class Observation:
    """What the camera path did at one observation time `t` [s]."""

    t: float
    truth: Poses
    row_x: np.ndarray
    row_y: np.ndarray
    blobs: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    outcome: list[tuple[str, int]] = field(default_factory=list)


@dataclass
class Audit:
    """The observations of one episode and the bookkeeping's attributions."""

    speed: float
    observations: list[Observation] = field(default_factory=list)
    booked: dict[int, int | None] = field(default_factory=dict)
    left: set[int] = field(default_factory=set)
    detected: set[int] = field(default_factory=set)
    entered: int = 0


def _poses(episode: Episode) -> Poses:
    """True poses of the items resting on the belt from just before the camera line on."""
    items = episode.cell.items
    assert episode.parts is not None  # built by reset
    held = set(int(s) for s in episode.parts.held())
    slots = [int(s) for s in items.active_slots() if int(s) not in held]
    if not slots:
        empty = np.zeros(0)
        return Poses(np.zeros(0, np.int64), empty, empty, empty, empty, [])
    xyz = items.positions(np.array(slots))
    yaw = yaw_from_xmat(items.orientations(np.array(slots)))
    keep = (xyz[:, 0] > X_CAMERA - 0.4) & (xyz[:, 0] < X_CAMERA + 1.2)
    keep &= (np.abs(xyz[:, 1]) <= BELT_HALF_WIDTH) & (xyz[:, 2] > -0.05)
    pool = items.pool
    return Poses(
        np.array([pool.item_ids[s] for s in slots], np.int64)[keep],
        xyz[keep, 0],
        xyz[keep, 1],
        xyz[keep, 2],
        yaw[keep],
        [pool.item_type(s) for s, k in zip(slots, keep, strict=True) if k],
    )


def install(episode: Episode, audit: Audit) -> None:
    """Watch the episode's perception, tracker and attribution (after `reset`)."""
    perception, tracker = episode.perception, episode.tracker
    observe, update = perception.observe, tracker.update
    captured: list = []

    def blobs_of(pixel_b, pixel_y, *args, **kwargs):
        blobs = original_blobs(pixel_b, pixel_y, *args, **kwargs)
        b = [np.asarray(a, float) for row in pixel_b for a in row if len(a)]
        y = [np.asarray(a, float) for row in pixel_y for a in row if len(a)]
        all_b = np.concatenate(b) if b else np.zeros(0)
        all_y = np.concatenate(y) if y else np.zeros(0)
        captured[:] = [(all_b[blob.members], all_y[blob.members]) for blob in blobs]
        return blobs

    def watched_observe(t):
        captured.clear()
        detections = observe(t)
        travel = X_CAMERA + audit.speed * t
        newest_b = [np.asarray(a, float) for a in perception.pixels[-1]]
        newest_y = [np.asarray(a, float) for a in perception.pixel_y[-1]]
        obs = Observation(
            t,
            _poses(episode),
            travel - np.concatenate(newest_b) if newest_b else np.zeros(0),
            np.concatenate(newest_y) if newest_y else np.zeros(0),
            [(travel - b, y) for b, y in captured],
        )
        audit.observations.append(obs)
        return detections

    def watched_update(detections):
        created = []
        obs = audit.observations[-1] if audit.observations else None
        for det in detections:
            match = tracker.match(det)
            new = update([det])
            created += new
            if obs is not None:
                if new:
                    obs.outcome.append(("new", new[0].track_id))
                else:
                    obs.outcome.append(("joined", match.track_id if match else -1))
        return created

    def watched_attributed(track, *args, **kwargs):
        item_id = original_attributed(track, *args, **kwargs)
        audit.booked[int(track.track_id)] = item_id
        return item_id

    original_blobs = perception_module.item_blobs
    original_attributed = item_checks_module.attributed_item
    perception_module.item_blobs = blobs_of
    item_checks_module.attributed_item = watched_attributed
    perception.observe = watched_observe
    tracker.update = watched_update  # type: ignore[method-assign]  # watched for the audit


def _owner(obs: Observation, px: np.ndarray, py: np.ndarray) -> np.ndarray:
    """The item (index into obs.truth, -1: none) each pixel lies on, the highest first."""
    truth = obs.truth
    owner = np.full(px.size, -1, np.int64)
    top = np.full(px.size, -np.inf)
    for n in range(truth.item_id.size):
        item_type = truth.types[n]
        reach = math.hypot(item_type.half_length, item_type.half_width) + GROW_M
        near = np.flatnonzero(
            (np.abs(px - truth.x[n]) <= reach) & (np.abs(py - truth.y[n]) <= reach)
        )
        if near.size == 0:
            continue
        lx, ly = to_body(px[near], py[near], truth.x[n], truth.y[n], truth.yaw[n])
        on = near[contains_grown(item_type, lx, ly, GROW_M)]
        higher = on[truth.z[n] > top[on]]
        owner[higher], top[higher] = n, truth.z[n]
    return owner


def classify(audit: Audit) -> dict[int, tuple[str, float]]:
    """(stage, visible share) of every item that entered and left the belt."""
    seen_px: Counter = Counter()
    area: dict[int, float] = {}
    blob_px: dict[int, Counter] = {}  # item -> {(obs, blob): its pixels there}
    blob_owner: dict[tuple[int, int], int] = {}
    for k, obs in enumerate(audit.observations):
        ids = obs.truth.item_id
        for n, item_type in enumerate(obs.truth.types):
            area.setdefault(int(ids[n]), item_type.footprint_area)
        owner = _owner(obs, obs.row_x, obs.row_y)
        for n, count in Counter(owner[owner >= 0].tolist()).items():
            seen_px[int(ids[n])] += count
        for j, (bx, by) in enumerate(obs.blobs):
            owner = _owner(obs, bx, by)
            counts = Counter(owner[owner >= 0].tolist())
            for n, count in counts.items():
                blob_px.setdefault(int(ids[n]), Counter())[(k, j)] += count
            main = counts.most_common(1)
            blob_owner[(k, j)] = (
                int(ids[main[0][0]]) if main and main[0][1] >= 0.5 * bx.size else -1
            )
    stages = {}
    for item in sorted(audit.left):
        visible = min(1.0, seen_px[item] * PIXEL_M**2 / area[item]) if item in area else 0.0
        if item in audit.detected:
            stage = "detected"
        elif seen_px[item] == 0:
            stage = "not seen"
        elif item not in blob_px:
            stage = "not reported"
        else:
            (k, j), _ = blob_px[item].most_common(1)[0]
            if blob_owner[(k, j)] != item:
                stage = "merged"
            else:
                kind, _ = audit.observations[k].outcome[j]
                stage = "tracker" if kind == "joined" else "attribution"
        stages[item] = (stage, visible)
    return stages


def audit_episode(items: int, seed: int, duration_s: float = 90.0, speed_factor: float = 1.0):
    """Runs one camera episode watched; returns its `Audit`."""
    config = episode_config.load(
        None,
        perception="camera",
        items=items,
        duration_s=duration_s,
        seed=seed,
        speed_factor=speed_factor,
    )
    cell = config_cell(config)
    with Episode(config, cell) as episode:
        episode.reset()
        audit = Audit(episode.speed)
        install(episode, audit)
        episode.run()
        metrics = episode.metrics
        audit.left = set(metrics.binned) | metrics.missed | metrics.dropped
        audit.detected = set(metrics.detected)
        audit.entered = metrics.n_entered
    return audit


def main(argv: list[str] | None = None) -> int:
    """Prints, per seed, how many items each stage lost."""
    parser = argparse.ArgumentParser(
        prog="python -m sim.evaluation.detection_audit", description=__doc__
    )
    parser.add_argument("--items", type=int, default=200)
    parser.add_argument("--duration", type=float, default=90.0)
    parser.add_argument("--speed-factor", type=float, default=1.0)
    parser.add_argument("--seeds", type=int, nargs="+", default=[20])
    args = parser.parse_args(argv)
    total: Counter = Counter()
    print(f"{'seed':>5}{'left':>6}" + "".join(f"{s:>14}" for s in STAGES))
    for seed in args.seeds:
        audit = audit_episode(args.items, seed, args.duration, args.speed_factor)
        stages = classify(audit)
        counts = Counter(stage for stage, _ in stages.values())
        total += counts
        total["left"] += len(stages)
        print(f"{seed:5d}{len(stages):6d}" + "".join(f"{counts[s]:14d}" for s in STAGES))
        lost = [(i, s, v) for i, (s, v) in stages.items() if s != "detected"]
        for item, stage, visible in lost:
            print(f"    item {item:4d} {stage:<13} visible {visible:.2f}")
    print(f"{'all':>5}{total['left']:6d}" + "".join(f"{total[s]:14d}" for s in STAGES))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
