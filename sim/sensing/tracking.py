"""Items tracked along the belt between the camera and the robot.

Perception reports items where the camera saw them (belt position, class probabilities) at the
time of the observation; from then on an item's position advances with the belt speed, as on a
real cell with a belt encoder. A detection close to an existing track (same belt point, after
advancing it) updates that track instead of creating a new one, so an item seen over several
grid rows or in overlapping extraction windows is tracked once.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from perception.codes import CLASS_NAMES


@dataclass(frozen=True)
class Detection:
    """An item reported by perception at time `t` [s]: belt position [m], class probabilities.

    `probs` are over the classes void, paper, plastic, aluminium (ids 1..4), summing to 1.
    `true_id` is the simulator's item id when perception is the ground truth, else None.
    """

    t: float
    x: float
    y: float
    probs: tuple[float, float, float, float]
    true_id: int | None = None


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
    """Tracks on a belt moving at a constant speed.

    Args:
        belt_speed: Belt speed [m/s].
        match_radius: Detections closer than this to a track's current position join it [m].
    """

    def __init__(self, belt_speed: float, match_radius: float = 0.06):
        self.belt_speed = float(belt_speed)
        self.match_radius = float(match_radius)
        self._tracks: dict[int, Track] = {}
        self._next_id = 0

    def __len__(self) -> int:
        return len(self._tracks)

    def update(self, detections: list[Detection]) -> list[Track]:
        """Merge `detections` into the tracks; returns the tracks created."""
        created = []
        for det in detections:
            track = self._match(det)
            if track is None:
                track = Track(
                    track_id=self._next_id,
                    t0=det.t,
                    x0=det.x,
                    y=det.y,
                    probs=np.asarray(det.probs, dtype=float),
                    true_id=det.true_id,
                    last_seen=det.t,
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

    def _match(self, det: Detection) -> Track | None:
        best, best_d = None, self.match_radius
        for track in self._tracks.values():
            if det.true_id is not None or track.true_id is not None:
                if det.true_id == track.true_id:
                    return track
                continue
            dx = track.x_at(det.t, self.belt_speed) - det.x
            d = float(np.hypot(dx, track.y - det.y))
            if d < best_d and track.predicted_class == int(np.argmax(det.probs[1:])) + 2:
                best, best_d = track, d
        return best

    def tracks(self) -> list[Track]:
        """All tracks, oldest first."""
        return list(self._tracks.values())

    def get(self, track_id: int) -> Track | None:
        """The track of `track_id`, or None once it was removed."""
        return self._tracks.get(track_id)

    def remove(self, track_id: int) -> Track | None:
        """Forget a track (picked, or gone past the robot)."""
        return self._tracks.pop(track_id, None)

    def remove_true(self, true_id: int) -> list[Track]:
        """Forget and return the tracks of simulator item `true_id` (truth mode; none
        otherwise)."""
        gone = [k for k, tr in self._tracks.items() if tr.true_id == true_id]
        return [self._tracks.pop(k) for k in gone]

    def prune(self, t: float, x_max: float) -> list[Track]:
        """Remove and return the tracks whose position at `t` [s] is beyond `x_max` [m]."""
        gone = [k for k, tr in self._tracks.items() if tr.x_at(t, self.belt_speed) > x_max]
        return [self._tracks.pop(k) for k in gone]
