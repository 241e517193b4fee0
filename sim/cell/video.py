"""The episode's video: the cell from a free camera over the belt with overlays, as H.264 MP4.

Frames are rendered off-screen with one reused `mujoco.Renderer` at a small size (default
640x360) at a fixed rate of simulated time, then annotated with OpenCV: each tracked item's
predicted class next to it (where the cell believes it is), the chosen next pick boxed, the
pick/miss counters and the profit. The MP4 is written by imageio-ffmpeg to a temporary file and
renamed into place when the episode ends, so a killed run leaves no half-written video; the
temporary follows `sim.paths.temporary_path`, so the next run removes a killed run's leftover.
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

# The view: the belt from the camera box (x = -1.48) to the robot and its bins.
LOOKAT = (-0.55, 0.0, 0.0)
DISTANCE = 2.5
AZIMUTH = 115.0
ELEVATION = -25.0
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


def annotate(frame: np.ndarray, uv: np.ndarray, overlay: Overlay) -> np.ndarray:
    """Draw the overlay on an RGB frame (in place) and return it."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    for (track_id, *_, cls, prob), (u, v) in zip(overlay.items, uv, strict=True):
        if not (np.isfinite(u) and np.isfinite(v)):
            continue
        p = (int(round(u)), int(round(v)))
        colour = CLASS_COLOURS.get(cls, (200, 200, 200))
        cv2.circle(frame, p, 3, colour, -1, cv2.LINE_AA)
        label = (
            f"{CLASS_SHORT.get(cls, '?')} {prob:.0%}" if prob < 0.995 else CLASS_SHORT.get(cls, "?")
        )
        cv2.putText(frame, label, (p[0] + 4, p[1] - 4), font, 0.33, colour, 1, cv2.LINE_AA)
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
    ]
    pick = None if episode.current_pick is None else episode.current_pick.track_id
    return Overlay(items=items, next_pick=pick, counters=counters)
