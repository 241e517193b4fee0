"""Items tracked along the belt between the camera and the robot.

Perception reports items where the camera saw them (belt position, class probabilities) at the
time of the observation; from then on an item's position advances with the belt speed, as on a
real cell with a belt encoder. A detection close to an existing track (same belt point, after
advancing it) updates that track instead of creating a new one, so an item seen over several
grid rows or in overlapping extraction windows is tracked once.

A line with a camera per robot reports each detection with the camera that saw it (0 the first,
upstream). A detection of a downstream camera first looks for a track that only cameras
upstream of it saw (`Tracker.fuse`): the nearest such track whose position advanced with the
belt lies within `fusion_gate` of it (`FUSION_GATE_M`, wider than the match radius: the track
has travelled 1.8-6 m since it was seen), whatever the class each camera gave, each track and
detection paired once, nearest pairs first. The item is then one track, placed where the newer
camera saw it (`confirm`). A detection no upstream track is near makes a new track: an item the
cameras upstream did not see (buried under another one an upstream robot picked, or merged with
a neighbour in their frames) or one an upstream robot's failed pick left on the belt.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from perception.codes import CLASS_NAMES


@dataclass(frozen=True)
class Detection:
    """An item reported by perception at time `t` [s]: belt position [m], class probabilities.

    `probs` are over void and the materials (ids 1..1+m; void, paper, plastic, aluminium for
    the thesis's), summing to 1.
    `true_id` is the simulator's item id when perception is the ground truth, else None.
    """

    t: float
    x: float
    y: float
    probs: tuple[float, ...]
    true_id: int | None = None
    camera: int = 0
    """The camera of a line that saw it, upstream first (0: the first, or the only one)."""


FUSION_GATE_M = 0.10
"""A downstream camera's detection joins a track only cameras upstream of it saw when it lies
within this of the track's position advanced with the belt [m] (`Tracker.fuse`)."""


@dataclass
class Track:
    """One item on the belt as the cell believes it is."""

    track_id: int
    t0: float
    x0: float
    y: float
    probs: np.ndarray
    true_id: int | None = None
    hits: int = 1
    last_seen: float = 0.0
    meta: dict = field(default_factory=dict)
    camera: int = 0
    """The most downstream camera that saw it (a line's camera per robot; else 0)."""

    def x_at(self, t: float, belt_speed: float) -> float:
        """Belt position [m] at time `t` [s] for a belt moving at `belt_speed` [m/s]."""
        return self.x0 + belt_speed * (t - self.t0)

    @property
    def predicted_class(self) -> int:
        """Most probable class id (2 paper, 3 plastic, 4 aluminium)."""
        return int(np.argmax(self.probs[1:])) + 2

    @property
    def predicted_name(self) -> str:
        """Name of the most probable class."""
        return CLASS_NAMES[self.predicted_class - 1]


class Tracker:
    """Tracks on a belt moving at a constant speed but where a fault changes it (`rebase`).

    Args:
        belt_speed: Belt speed [m/s].
        match_radius: Detections closer than this to a track's current position join it [m].
        fusion_gate: A downstream camera's detection closer than this to a track that only
            cameras upstream of it saw is that track's item [m] (`FUSION_GATE_M`).
    """

    def __init__(
        self, belt_speed: float, match_radius: float = 0.06, fusion_gate: float = FUSION_GATE_M
    ):
        self.belt_speed = float(belt_speed)
        self.match_radius = float(match_radius)
        self.fusion_gate = float(fusion_gate)
        self._tracks: dict[int, Track] = {}
        self._next_id = 0
        # (sim time [s], the speed before it [m/s]) of each change of the belt's speed (`rebase`).
        self._speed_changes: list[tuple[float, float]] = []

    def __len__(self) -> int:
        return len(self._tracks)

    def update(self, detections: list[Detection]) -> list[Track]:
        """Merge `detections` into the tracks; returns the tracks created."""
        created = []
        fused = self.fuse(detections)
        for index, det in enumerate(detections):
            if index in fused:
                confirm(fused[index], det)
                continue
            track = self.match(det)
            if track is None:
                track = Track(
                    track_id=self._next_id,
                    t0=det.t,
                    x0=det.x,
                    y=det.y,
                    probs=np.asarray(det.probs, dtype=float),
                    true_id=det.true_id,
                    last_seen=det.t,
                    camera=det.camera,
                )
                self._tracks[track.track_id] = track
                self._next_id += 1
                created.append(track)
            elif det.true_id is not None:  # ground truth: the latest position is exact
                track.x0, track.y, track.t0 = det.x, det.y, det.t
                track.hits += 1
                track.last_seen = det.t
            else:
                n = track.hits
                x_now = track.x_at(det.t, self.belt_speed)
                track.x0 = (x_now * n + det.x) / (n + 1)
                track.y = (track.y * n + det.y) / (n + 1)
                track.t0 = det.t
                track.probs = (track.probs * n + np.asarray(det.probs)) / (n + 1)
                track.hits = n + 1
                track.last_seen = det.t
        return created

    def match(self, det: Detection) -> Track | None:
        """The track `det` updates (`update`): the same simulator item in truth mode, else the
        nearest track of the same camera and predicted class within `match_radius`; None."""
        best, best_d = None, self.match_radius
        for track in self._tracks.values():
            if det.true_id is not None or track.true_id is not None:
                if det.true_id == track.true_id:
                    return track
                continue
            if track.camera != det.camera:  # another camera's track: `fuse`'s
                continue
            dx = track.x_at(det.t, self.belt_speed) - det.x
            d = float(np.hypot(dx, track.y - det.y))
            if d < best_d and track.predicted_class == int(np.argmax(det.probs[1:])) + 2:
                best, best_d = track, d
        return best

    def fuse(self, detections: list[Detection]) -> dict[int, Track]:
        """The tracks that detections of downstream cameras are of: for each camera detection
        (index into `detections`) of a camera after the first, the nearest track that only
        cameras upstream of it saw, within `fusion_gate` of the track's position advanced with
        the belt; nearest pairs first, each track and detection at most once, the classes not
        compared (two cameras may class an item differently)."""
        pairs = []
        for index, det in enumerate(detections):
            if det.camera == 0 or det.true_id is not None:
                continue
            for track in self._tracks.values():
                if track.camera < det.camera and track.true_id is None:
                    dx = track.x_at(det.t, self.belt_speed) - det.x
                    d = float(np.hypot(dx, track.y - det.y))
                    if d < self.fusion_gate:
                        pairs.append((d, index, track.track_id))
        fused: dict[int, Track] = {}
        taken = set()
        for _, index, track_id in sorted(pairs):
            if index not in fused and track_id not in taken:
                fused[index] = self._tracks[track_id]
                taken.add(track_id)
        return fused

    def tracks(self) -> list[Track]:
        """All tracks, oldest first."""
        return list(self._tracks.values())

    def get(self, track_id: int) -> Track | None:
        """The track of `track_id`, or None once it was removed."""
        return self._tracks.get(track_id)

    def remove(self, track_id: int) -> Track | None:
        """Forget a track (picked, or gone past the robot)."""
        return self._tracks.pop(track_id, None)

    def rebase(self, t: float, belt_speed: float) -> None:
        """The belt runs at `belt_speed` [m/s] from sim time `t` [s] on: every track is placed
        where the old speed has carried it by `t`, and moves on at the new one."""
        for track in self._tracks.values():
            track.x0, track.t0 = track.x_at(t, self.belt_speed), t
        self._speed_changes.append((float(t), self.belt_speed))
        self.belt_speed = float(belt_speed)

    def speed_changed_since(self, t: float) -> bool:
        """Whether the belt's speed changed after sim time `t` [s] (a belt fault began or
        ended): a pick planned at `t` met its item at the old speed."""
        return any(changed > t for changed, _ in self._speed_changes)

    def restore(self, track: Track) -> None:
        """Track `track` again (removed for a pick that was given up: its item is offered
        again), placed where the belt carried it through the changes of its speed meanwhile."""
        for t, speed in self._speed_changes:
            if t > track.t0:
                track.x0, track.t0 = track.x_at(t, speed), t
        self._tracks[track.track_id] = track

    def remove_true(self, true_id: int) -> list[Track]:
        """Forget and return the tracks of simulator item `true_id` (truth mode; none
        otherwise)."""
        gone = [k for k, tr in self._tracks.items() if tr.true_id == true_id]
        return [self._tracks.pop(k) for k in gone]

    def prune(self, t: float, x_max: float) -> list[Track]:
        """Remove and return the tracks whose position at `t` [s] is beyond `x_max` [m]."""
        gone = [k for k, tr in self._tracks.items() if tr.x_at(t, self.belt_speed) > x_max]
        return [self._tracks.pop(k) for k in gone]


def confirm(track: Track, det: Detection) -> None:
    """A downstream camera saw the item of `track` (`Tracker.fuse`): the track is placed where
    that camera saw it (the belt's travel since and any slip of the item are left behind), its
    class probabilities are the mean of every report's, and it is that camera's from now on.

    Args:
        track: The track, updated in place (a new probabilities array).
        det: The downstream camera's detection.
    """
    n = track.hits
    track.x0, track.y, track.t0 = det.x, det.y, det.t
    track.probs = (track.probs * n + np.asarray(det.probs, dtype=float)) / (n + 1)
    track.hits = n + 1
    track.last_seen = det.t
    track.camera = det.camera
