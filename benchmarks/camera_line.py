"""A line's camera perception with one camera against a camera per robot, and truth.

Runs a line's episodes (default: four coordinated robots, 300 items in 90 s, x1, 50 mm cups as
`experiments/line.toml`) with truth perception, the one belt camera and a camera per robot
(`[camera] per_robot`), and prints per episode and on average: items picked, profit, items
never detected, items in a wrong bin, duplicate tracks, real-time factor (simulated over wall
time, and over this process's CPU time, which other work on the machine does not lower). A
duplicate is a new track the evaluation's attribution (`sim.sensing.attribution`)
books to an item another live track is already booked to: two tracks of one item at once (an
item tracked again after its track was taken for a pick that failed is not one). For a camera
per robot it also prints how far each downstream camera's detection of an item lay from the
position of that item's upstream track advanced with the belt (the fusion gate's margin).

    python benchmarks/camera_line.py --seeds 600 601 602 603 604 [--modes truth camera per_robot]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

import sim.episode.item_checks as item_checks  # noqa: E402
from sim import config as episode_config  # noqa: E402
from sim.episode.loop import Episode  # noqa: E402
from sim.episode.runner import config_cell  # noqa: E402
from sim.sensing.tracking import Track  # noqa: E402

MODES = ("truth", "camera", "per_robot")


def _config(mode: str, seed: int, args) -> episode_config.EpisodeConfig:
    return episode_config.from_dict(
        {
            "perception": "truth" if mode == "truth" else "camera",
            "robots": args.robots,
            "items": args.items,
            "duration_s": args.duration,
            "seed": seed,
            "cup": {"diameter_m": 0.05},
            "camera": {"per_robot": mode == "per_robot"},
        }
    )


class Watch:
    """The attribution of every new track, and each downstream detection's distance to its
    item's upstream track."""

    def __init__(self, episode: Episode):
        self.episode = episode
        self.booked: dict[int, int | None] = {}
        self.duplicates = 0
        self.errors: list[float] = []  # downstream detection to its item's upstream track [m]
        self.unmatched_far = 0  # downstream detections of an item tracked upstream, past the gate
        self.duplicates_by_camera: dict[int, int] = {}
        self.fused = 0
        self.wrong_fusions = 0  # a downstream detection joined to another item's track
        self.camera_of: dict[int, int] = {}

    def attributed(self, original):
        def watched(track, t, speed, items_xy, gate, shapes=None):
            item = original(track, t, speed, items_xy, gate, shapes)
            live = {self.booked.get(tr.track_id) for tr in self.episode.tracker.tracks()
                    if tr.track_id != track.track_id}  # fmt: skip
            if item is not None and item in live:
                self.duplicates += 1
                camera = track.camera
                self.duplicates_by_camera[camera] = self.duplicates_by_camera.get(camera, 0) + 1
            self.booked[track.track_id] = item
            self.last_items = (items_xy, shapes)
            return item

        return watched

    def update(self, original, attributed):
        def watched(detections):
            downstream = [d for d in detections if d.camera > 0]
            if downstream:
                self._errors(downstream, attributed)
            return original(detections)

        return watched

    def fuse(self, original, attributed):
        def watched(detections):
            fused = original(detections)
            if fused:
                xy, shapes = self._truth()
                for index, track in fused.items():
                    det = detections[index]
                    probe = Track(-1, det.t, det.x, det.y, np.asarray(det.probs))
                    item = attributed(probe, det.t, self.episode.speed, xy, 0.06, shapes)
                    self.fused += 1
                    booked = self.booked.get(track.track_id)
                    if item is not None and booked is not None and item != booked:
                        self.wrong_fusions += 1
            return fused

        return watched

    def _truth(self):
        episode = self.episode
        items = episode.cell.items
        held = episode.parts.held()
        xy, shapes = {}, {}
        for slot in items.active_slots():
            if slot not in held:
                x, y = items.position(slot)[:2]
                item_id = int(items.pool.item_ids[slot])
                xy[item_id] = (float(x), float(y))
                shapes[item_id] = (item_checks.yaw_of(items, int(slot)), items.pool.item_type(slot))
        return xy, shapes

    def _errors(self, detections, attributed) -> None:
        episode = self.episode
        xy, shapes = self._truth()
        tracks = episode.tracker.tracks()
        for det in detections:
            probe = Track(-1, det.t, det.x, det.y, np.asarray(det.probs))
            item = attributed(probe, det.t, episode.speed, xy, 0.06, shapes)
            if item is None:
                continue
            same = [tr for tr in tracks if tr.camera < det.camera
                    and self.booked.get(tr.track_id) == item]  # fmt: skip
            for tr in same:
                d = float(np.hypot(tr.x_at(det.t, episode.speed) - det.x, tr.y - det.y))
                self.errors.append(d)
                if d >= episode.tracker.fusion_gate:
                    self.unmatched_far += 1


def run(mode: str, seed: int, args) -> dict:
    config = _config(mode, seed, args)
    cell = config_cell(config)
    original = item_checks.attributed_item
    wall0, cpu0 = time.perf_counter(), time.process_time()
    with Episode(config, cell) as episode:
        episode.reset()
        watch = Watch(episode)
        item_checks.attributed_item = watch.attributed(original)
        tracker = episode.tracker
        if args.gate is not None:
            tracker.fusion_gate = args.gate
        tracker.update = watch.update(tracker.update, original)
        tracker.fuse = watch.fuse(tracker.fuse, original)
        try:
            episode.run()
        finally:
            item_checks.attributed_item = original
        row = episode.metrics.row()
        sim_s = float(episode.data.time)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    errors = np.array(watch.errors)
    return {
        "mode": mode,
        "seed": seed,
        "picked": row["picked"],
        "profit_eur": row["profit_eur"],
        "never_detected": row["never_detected"],
        "wrong_bin": row["wrong_bin"],
        "duplicates": watch.duplicates,
        "mujoco_warnings": row.get("mujoco_warnings"),
        "attempts": row["attempts"],
        "failed_picks": row["failed_picks"],
        "rtf": sim_s / wall,
        "rtf_cpu": sim_s / cpu,
        "fusion_errors_m": (
            [float(np.percentile(errors, q)) for q in (50, 90, 99, 100)] if errors.size else []
        ),
        "downstream_past_gate": watch.unmatched_far,
        "duplicates_by_camera": watch.duplicates_by_camera,
        "fused": watch.fused,
        "wrong_fusions": watch.wrong_fusions,
        "fusion_error_histogram_cm": dict(
            zip(
                ("0-1", "1-2", "2-4", "4-6", "6-8", "8-10", "10-15", "15-"),
                np.histogram(100 * errors, [0, 1, 2, 4, 6, 8, 10, 15, 1e9])[0].tolist(),
                strict=True,
            )
        ),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[600])
    parser.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)
    parser.add_argument("--robots", type=int, default=4)
    parser.add_argument("--items", type=int, default=300)
    parser.add_argument("--duration", type=float, default=90.0)
    parser.add_argument("--gate", type=float, default=None, help="fusion gate [m] (the tracker's)")
    args = parser.parse_args()
    rows = []
    for seed in args.seeds:
        for mode in args.modes:
            rows.append(run(mode, seed, args))
            print(json.dumps(rows[-1]), flush=True)
    keys = (
        "picked",
        "profit_eur",
        "never_detected",
        "wrong_bin",
        "duplicates",
        "failed_picks",
        "rtf",
        "rtf_cpu",
    )
    for mode in args.modes:
        mine = [r for r in rows if r["mode"] == mode]
        means = "  ".join(f"{k} {np.mean([r[k] for r in mine]):.2f}" for k in keys)
        print(f"{mode:10s} {len(mine)} episodes: {means}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
