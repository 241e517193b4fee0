"""The episode's video: the cell from a free camera over the belt with overlays, as H.264 MP4.

Frames are rendered off-screen with one reused `mujoco.Renderer` at a small size (default
640x360) at a fixed rate of simulated time, from a view over the whole belt (the camera box to
the discharge), the robot and all three bins, the robot's cage and the camera box drawn
see-through; then annotated with OpenCV: each tracked item's predicted class next to it (where the
cell believes it is; labels never overlap, a crowded item keeps its dot only), the chosen next
pick boxed, the pick/miss counters, the profit and each bin's purity so far. The MP4 is written
by imageio-ffmpeg to a temporary file and renamed into place when the episode ends, so a killed
run leaves no half-written video; the temporary follows `sim.paths.temporary_path`, so the next
run removes a killed run's leftover.
`check_encoder` proves, before an episode runs, that the H.264 encoder works here.
"""

from __future__ import annotations

import contextlib
import functools
import os
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import imageio.v2 as imageio
import mujoco
import numpy as np

from sim.cell.rendering import check_backend
from sim.errors import InvalidInput
from sim.paths import temporary_path

# The view: from above the paper bin's side, the whole belt from the camera box (x = -1.48) to
# the discharge, the robot and all three bins.
LOOKAT = (-0.35, 0.0, 0.15)
DISTANCE = 3.3
AZIMUTH = 135.0
ELEVATION = -48.0
GHOSTED_PREFIXES = ("cage_", "camera_box_")
"""Geoms drawn see-through in the video (the robot's cage and the camera's box would hide the
belt and the robot), by name prefix in the MJCF."""
GHOST_ALPHA = 0.12
LABEL_OFFSETS = ((4, -4), (4, 12), (-34, -4), (-34, 12), (4, -18), (-34, -18), (4, 26))
"""Where a label is tried around its item's dot [px], in turn, until it overlaps no other."""
# BGR-free: frames are RGB; one colour per predicted class (paper, plastic, aluminium).
CLASS_COLOURS = {2: (230, 170, 60), 3: (80, 200, 255), 4: (235, 235, 235)}
CLASS_SHORT = {2: "PAP", 3: "PL", 4: "AL"}


@dataclass
class Overlay:
    """What the frame's annotations show.

    Attributes:
        items: (track id, x, y, z, predicted class id, probability) of each tracked item [m].
        next_pick: Track id of the chosen next pick, or None.
        counters: Lines of text for the top-left corner.
    """

    items: list[tuple[int, float, float, float, int, float]] = field(default_factory=list)
    next_pick: int | None = None
    counters: list[str] = field(default_factory=list)


def view_camera() -> mujoco.MjvCamera:
    """A free camera framing the belt from the camera box to the robot and the bins."""
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = LOOKAT
    cam.distance, cam.azimuth, cam.elevation = DISTANCE, AZIMUTH, ELEVATION
    return cam


def ghosted_geoms(model: mujoco.MjModel) -> frozenset[int]:
    """Ids of the geoms the video draws see-through (`GHOSTED_PREFIXES`)."""
    return frozenset(
        i for i in range(model.ngeom) if model.geom(i).name.startswith(GHOSTED_PREFIXES)
    )


def ghost(scene: mujoco.MjvScene, geom_ids: frozenset[int], alpha: float = GHOST_ALPHA) -> None:
    """Make the scene's copies of `geom_ids` see-through (after `update_scene`)."""
    for k in range(scene.ngeom):
        g = scene.geoms[k]
        if g.objtype == mujoco.mjtObj.mjOBJ_GEOM and g.objid in geom_ids:
            g.rgba[3] = alpha


def project(scene: mujoco.MjvScene, points: np.ndarray, size) -> np.ndarray:
    """Pixel coordinates (N, 2) of world `points` (N, 3) in the scene's rendered view."""
    width, height = size
    gl = scene.camera[0]
    forward, up = np.array(gl.forward), np.array(gl.up)
    right = np.cross(forward, up)
    rel = np.asarray(points, dtype=float) - np.array(gl.pos)
    depth = rel @ forward
    focal = 0.5 * height * gl.frustum_near / gl.frustum_top
    with np.errstate(divide="ignore", invalid="ignore"):
        u = width / 2.0 + focal * (rel @ right) / depth
        v = height / 2.0 - focal * (rel @ up) / depth
    uv = np.column_stack([u, v])
    uv[depth <= 1e-6] = np.nan
    return uv


def _overlaps(box, boxes) -> bool:
    x0, y0, x1, y1 = box
    return any(x0 < b[2] and b[0] < x1 and y0 < b[3] and b[1] < y1 for b in boxes)


def place_label(p, size, taken: list) -> tuple[int, int] | None:
    """Bottom-left corner of a label of `size` (w, h) [px] near the dot at `p`, at the first of
    `LABEL_OFFSETS` where it overlaps no box in `taken` (which it joins); None: no room."""
    w, h = size
    for dx, dy in LABEL_OFFSETS:
        x, y = p[0] + dx, p[1] + dy
        box = (x - 1, y - h - 1, x + w + 1, y + 2)
        if not _overlaps(box, taken):
            taken.append(box)
            return x, y
    return None


def annotate(frame: np.ndarray, uv: np.ndarray, overlay: Overlay) -> np.ndarray:
    """Draw the overlay on an RGB frame (in place) and return it.

    Every item gets its dot; labels are placed so that none overlaps another or the counters'
    panel (`place_label`), the next pick's first: where items crowd, some dots go unlabelled
    rather than have their labels pile up."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    taken = []
    if overlay.counters:
        h = 8 + 16 * len(overlay.counters)
        w = 12 + max(cv2.getTextSize(t, font, 0.42, 1)[0][0] for t in overlay.counters)
        taken.append((0, 0, w, h))
    order = sorted(zip(overlay.items, uv, strict=True), key=lambda e: e[0][0] != overlay.next_pick)
    for (track_id, *_, cls, prob), (u, v) in order:
        if not (np.isfinite(u) and np.isfinite(v)):
            continue
        p = (int(round(u)), int(round(v)))
        colour = CLASS_COLOURS.get(cls, (200, 200, 200))
        cv2.circle(frame, p, 3, colour, -1, cv2.LINE_AA)
        label = (
            f"{CLASS_SHORT.get(cls, '?')} {prob:.0%}" if prob < 0.995 else CLASS_SHORT.get(cls, "?")
        )
        (w, h), _ = cv2.getTextSize(label, font, 0.33, 1)
        corner = place_label(p, (w, h), taken)
        if corner is not None:
            cv2.putText(frame, label, corner, font, 0.33, colour, 1, cv2.LINE_AA)
        if track_id == overlay.next_pick:
            cv2.rectangle(frame, (p[0] - 10, p[1] - 10), (p[0] + 10, p[1] + 10), (255, 60, 60), 2)
            cv2.putText(
                frame, "next", (p[0] - 12, p[1] + 22), font, 0.35, (255, 60, 60), 1, cv2.LINE_AA
            )
    if overlay.counters:
        h = 8 + 16 * len(overlay.counters)
        w = 12 + max(cv2.getTextSize(t, font, 0.42, 1)[0][0] for t in overlay.counters)
        patch = frame[0:h, 0:w]
        patch[:] = (0.35 * patch).astype(frame.dtype)  # darkened panel behind the text
    y = 16
    for line in overlay.counters:
        cv2.putText(frame, line, (6, y), font, 0.42, (255, 255, 255), 1, cv2.LINE_AA)
        y += 16
    return frame


ENCODER = "libx264"
"""The H.264 encoder of imageio-ffmpeg's ffmpeg that writes the MP4s."""


@functools.cache
def _encoder_failure() -> str | None:
    """Why ffmpeg cannot encode H.264 here (None when it can): one frame encoded to nothing."""
    try:
        import imageio_ffmpeg

        exe = imageio_ffmpeg.get_ffmpeg_exe()
        probe = subprocess.run(
            [exe, "-hide_banner", "-loglevel", "error", "-f", "lavfi", "-i",
             "color=c=black:s=64x64:d=0.1", "-frames:v", "1", "-c:v", ENCODER,
             "-pix_fmt", "yuv420p", "-f", "null", "-"],
            capture_output=True, text=True, timeout=60, check=False,
        )  # fmt: skip
    except (OSError, RuntimeError, subprocess.SubprocessError) as exc:
        return f"{type(exc).__name__}: {exc}"
    if probe.returncode != 0:
        return (probe.stderr.strip().splitlines() or [f"ffmpeg exit {probe.returncode}"])[-1]
    return None


def check_encoder(field: str = "--video") -> None:
    """Refuse in one line, before any episode runs, when ffmpeg cannot write H.264 here.

    Raises:
        InvalidInput: imageio-ffmpeg's ffmpeg is missing or has no working libx264.
    """
    failure = _encoder_failure()
    if failure is not None:
        allowed = f"a video the encoder can write (imageio-ffmpeg's ffmpeg with {ENCODER})"
        raise InvalidInput(field, allowed, " ".join(failure.split())[:160])


class VideoRecorder:
    """Renders and annotates frames every 1/fps of simulated time into an MP4.

    Args:
        model: The compiled cell.
        path: Final MP4 path (written through a temporary file in the same folder).
        fps: Frames per simulated second (also the file's playback rate: real-time video).
        width: Frame width [px].
        height: Frame height [px].
    """

    def __init__(self, model: mujoco.MjModel, path: Path, fps: float, width: int, height: int):
        self.model = model
        self.path = Path(path)
        self.fps = float(fps)
        self.size = (int(width), int(height))
        self.cam = view_camera()
        check_backend()
        self.renderer = mujoco.Renderer(model, height=self.size[1], width=self.size[0])
        self._ghosts = ghosted_geoms(model)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = temporary_path(self.path, ".mp4")
        self._writer = imageio.get_writer(
            self._tmp,
            fps=self.fps,
            codec="libx264",
            quality=6,
            macro_block_size=8,
            pixelformat="yuv420p",
            ffmpeg_log_level="error",
        )
        self.frames = 0
        self._next_t = 0.0

    @property
    def next_frame_time(self) -> float:
        """Sim time of the next frame [s]."""
        return self._next_t

    def due(self, t: float) -> bool:
        """Whether a frame is due at simulated time `t` [s]."""
        return t + 1e-9 >= self._next_t

    def capture(self, data: mujoco.MjData, overlay: Overlay) -> None:
        """Render the current state, draw `overlay` and append the frame."""
        self.renderer.update_scene(data, camera=self.cam)
        ghost(self.renderer.scene, self._ghosts)
        frame = self.renderer.render().copy()
        pts = np.array([it[1:4] for it in overlay.items], dtype=float).reshape(-1, 3)
        annotate(frame, project(self.renderer.scene, pts, self.size), overlay)
        try:
            self._writer.append_data(frame)
        except (OSError, RuntimeError) as exc:  # ffmpeg died: a full disk, a vanished folder
            raise self._refusal(exc) from None
        self.frames += 1
        self._next_t = self.frames / self.fps

    def _refusal(self, exc: BaseException) -> InvalidInput:
        reason = " ".join(f"{type(exc).__name__}: {exc}".split())[:160]
        return InvalidInput("video", "a place the video encoder can write", reason, str(self.path))

    def close(self) -> Path:
        """Finish the MP4 and move it into place."""
        try:
            self._writer.close()
        except (OSError, RuntimeError) as exc:
            self.renderer.close()
            Path(self._tmp).unlink(missing_ok=True)
            raise self._refusal(exc) from None
        self.renderer.close()
        if Path(self._tmp).exists():
            os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Drop the partial video (the episode failed; a failing encoder is not reported again)."""
        try:
            with contextlib.suppress(OSError, RuntimeError):
                self._writer.close()
        finally:
            self.renderer.close()
            Path(self._tmp).unlink(missing_ok=True)


def overlay_of(episode, t: float) -> Overlay:
    """The annotations of an episode's frame at sim time `t` [s]."""
    items = []
    tracks = episode.tracker.tracks()
    if episode.current_pick is not None:
        tracks.append(episode.current_pick)
    for tr in tracks:
        cls = tr.predicted_class
        items.append((tr.track_id, tr.x_at(t, episode.speed), tr.y, 0.03, cls, tr.probs[cls - 1]))
    m = episode.metrics
    counters = [
        f"t {t:5.1f} s  x{episode.config.speed_factor:g}  {episode.config.planner}  "
        f"{episode.config.perception}",
        f"entered {m.n_entered}  picked {m.n_picked}  missed {len(m.missed)}",
        f"profit {m.profit:.2f} EUR",
        "purity " + purity_text(m.binned),
    ]
    pick = None if episode.current_pick is None else episode.current_pick.track_id
    return Overlay(items=items, next_pick=pick, counters=counters)


def purity_text(binned: dict[int, tuple[int, int]]) -> str:
    """'PAP 1.00  PL 0.95  AL -': each bin's share of items of its own class so far ('-' for
    an empty bin), from {item: (true class, bin class)}."""
    parts = []
    for cls, short in CLASS_SHORT.items():
        in_bin = [t for t, b in binned.values() if b == cls]
        share = f"{sum(t == cls for t in in_bin) / len(in_bin):.2f}" if in_bin else "-"
        parts.append(f"{short} {share}")
    return "  ".join(parts)
