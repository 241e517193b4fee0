"""The episode's video: the cell from a free camera over the belt with overlays, as H.264 MP4.

Frames are rendered off-screen at a small size (default 640x360) at a fixed rate of simulated
time, from a view over the whole belt (the camera box to the discharge), the robot and all three
bins, the robot's cage and the camera box drawn see-through; then annotated with OpenCV: each
tracked item's predicted class next to it (where the cell believes it is; labels never overlap, a
crowded item keeps its dot only), the chosen next pick boxed, the pick/miss counters, the profit
and each bin's purity so far.

The frames are rendered, annotated and encoded in a process of their own (`VideoRecorder`), so
the episode's process only sends, per frame, what the frame is drawn from (`FrameState`): the
joint positions, the mocap poses, the rows of the model fields the simulation changed since the
last frame (`MODEL_FIELDS`: an item taking its size, colour and visibility at spawn) and the
overlay. The video process holds its own copy of the model and data and draws with
`FramePainter`, which tests and benchmarks also use in-process.

The MP4 is written by imageio-ffmpeg to a temporary file and renamed into place when the episode
ends, so a killed run leaves no half-written video: the video process drops it when the
episode's process goes away, and the temporary follows `sim.paths.temporary_path` (named after
the episode's process), so the next run removes any leftover. `check_encoder` proves, before an
episode runs, that the H.264 encoder works here. A failure in the video process reaches the
episode's process as one line: a refusal (exit code 2) when the encoder cannot write,
`VideoError` (exit code 1) otherwise.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import multiprocessing
import os
import resource
import signal
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import imageio.v2 as imageio
import mujoco
import numpy as np

from sim.cell.rendering import check_backend
from sim.errors import InvalidInput, RefusedInput, SortsimError
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
PALETTE = (
    (230, 170, 60), (80, 200, 255), (235, 235, 235), (120, 230, 120),
    (255, 120, 200), (255, 230, 90), (170, 140, 255), (255, 140, 90),
)  # fmt: skip
"""Label colours of a catalogue's materials, in material order (the first three the thesis's)."""
_THESIS_SHORT = {"paper": "PAP", "plastic": "PL", "aluminium": "AL"}


def class_labels(materials) -> tuple[dict[int, str], dict[int, tuple[int, int, int]]]:
    """({class id: short label}, {class id: RGB}) of `materials`' classes for the overlays:
    the thesis's PAP, PL, AL, else the name's first four letters in capitals (PET, HDPE)."""
    pairs = zip(materials.ids, materials.names, strict=True)
    short = {c: _THESIS_SHORT.get(n, n[:4].upper()) for c, n in pairs}
    colours = {c: PALETTE[k % len(PALETTE)] for k, c in enumerate(materials.ids)}
    return short, colours


@dataclass
class Overlay:
    """What the frame's annotations show.

    Attributes:
        items: (track id, x, y, z, predicted class id, probability) of each tracked item [m].
        next_pick: Track id of the chosen next pick, or None.
        next_picks: Track ids of every robot's pick under way (a line's robots), with
            `next_pick` among them.
        counters: Lines of text for the top-left corner.
    """

    items: list[tuple[int, float, float, float, int, float]] = field(default_factory=list)
    next_pick: int | None = None
    next_picks: tuple[int, ...] = ()
    counters: list[str] = field(default_factory=list)
    short: dict[int, str] = field(default_factory=lambda: dict(CLASS_SHORT))
    """Short label of each class id (the materials')."""
    colours: dict[int, tuple[int, int, int]] = field(default_factory=lambda: dict(CLASS_COLOURS))
    """RGB of each class id's labels."""


def last_robot_x(model: mujoco.MjModel | None) -> float:
    """x of the most downstream robot's base [m] (0 for the single cell; a line's last)."""
    if model is None:
        return 0.0
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    xs = [
        float(data.xpos[b][0])
        for b in range(model.nbody)
        if (model.body(b).name or "").endswith("base_link")
    ]
    return max(xs, default=0.0)


def view_camera(model: mujoco.MjModel | None = None) -> mujoco.MjvCamera:
    """A free camera framing the belt from the camera box to the robot and the bins; for a
    line, to its last robot (farther back, centred on the line)."""
    span = last_robot_x(model)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = (LOOKAT[0] + 0.5 * span, LOOKAT[1], LOOKAT[2])
    cam.distance, cam.azimuth, cam.elevation = DISTANCE + 0.6 * span, AZIMUTH, ELEVATION
    return cam


def ghosted_geoms(model: mujoco.MjModel) -> frozenset[int]:
    """Ids of the geoms the video draws see-through (`GHOSTED_PREFIXES`, after a line's robot
    prefix too: `r1_cage_*`)."""
    return frozenset(
        i
        for i in range(model.ngeom)
        if (name := model.geom(i).name).startswith(GHOSTED_PREFIXES)
        or name.partition("_")[2].startswith(GHOSTED_PREFIXES)
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
    picks = {overlay.next_pick, *overlay.next_picks} - {None}
    order = sorted(zip(overlay.items, uv, strict=True), key=lambda e: e[0][0] not in picks)
    for (track_id, *_, cls, prob), (u, v) in order:
        if not (np.isfinite(u) and np.isfinite(v)):
            continue
        p = (int(round(u)), int(round(v)))
        colour = overlay.colours.get(cls, (200, 200, 200))
        cv2.circle(frame, p, 3, colour, -1, cv2.LINE_AA)
        name = overlay.short.get(cls, "?")
        label = f"{name} {prob:.0%}" if prob < 0.995 else name
        (w, h), _ = cv2.getTextSize(label, font, 0.33, 1)
        corner = place_label(p, (w, h), taken)
        if corner is not None:
            cv2.putText(frame, label, corner, font, 0.33, colour, 1, cv2.LINE_AA)
        if track_id in picks:
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
ENCODER_PRESET = "veryfast"
"""x264's speed preset: 3.6 ms a 640x360 frame against 8.3 ms for its default (medium), for a
file 5 % smaller at the same quality setting (crf 20) on the headline episode's frames."""
SAMPLES = 0
"""Multisampling of the video's renders: none. Mesa's software renderer draws 2 and 4 samples
at the same cost, 2.6 times that of none (62 against 24 ms a 640x360 frame); without it thin
edges (the cage's bars, the belt's rims) show stair-steps, which the H.264 encoding softens."""
BOX_QUADS = 1
"""Quads per side of a box's face in the video's renders (MuJoCo's default: 4, for smoother
lighting of large boxes): 18 against 27 ms a frame with the floor below, 9 pixels of a frame
changed by more than 8 levels of 255."""
FLOOR_HALF_SIZE_M = 10.0
"""The video draws an infinite textured floor as a square of this half size with the same
texture scale: the same pixels (the view sees the floor within 6 m), fewer triangles."""
MODEL_FIELDS = (
    "geom_size",
    "geom_rgba",
    "geom_quat",
    "geom_pos",
    "geom_group",
    "geom_type",
    "geom_matid",
    "geom_dataid",
    "body_pos",
    "body_quat",
    "mat_rgba",
)
"""Model fields a frame is drawn from that the simulation may change while it runs (the item
pool sets an item's geom size, orientation, colour and group at spawn and hides it at park);
the video process receives the rows that changed since the previous frame."""


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


@dataclass
class FrameState:
    """What a frame is drawn from, besides the model the video process was started with.

    Attributes:
        qpos: The joint positions (nq,).
        mocap_pos: Mocap bodies' positions (nmocap, 3).
        mocap_quat: Mocap bodies' orientations (nmocap, 4).
        model_rows: Per changed field of `MODEL_FIELDS`: (row indices, their new values).
    """

    qpos: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat: np.ndarray
    model_rows: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)


class ModelWatch:
    """Finds the rows of `MODEL_FIELDS` a model changed since the previous look."""

    def __init__(self, model: mujoco.MjModel):
        self._last = {n: getattr(model, n).copy() for n in MODEL_FIELDS if hasattr(model, n)}

    def changes(self, model: mujoco.MjModel) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """{field: (rows, values)} of the rows that differ from the previous look."""
        out = {}
        for name, last in self._last.items():
            now = getattr(model, name)
            differs = now != last
            if differs.ndim > 1:
                differs = differs.any(axis=tuple(range(1, differs.ndim)))
            if differs.any():
                rows = np.flatnonzero(differs)
                values = now[rows].copy()
                last[rows] = values
                out[name] = (rows, values)
        return out


def frame_state(
    model: mujoco.MjModel, data: mujoco.MjData, watch: ModelWatch | None = None
) -> FrameState:
    """The state of `data` (and, with `watch`, the model rows changed since its last look)."""
    return FrameState(
        data.qpos.copy(),
        data.mocap_pos.copy(),
        data.mocap_quat.copy(),
        {} if watch is None else watch.changes(model),
    )


def finite_floors(model: mujoco.MjModel, half_size: float = FLOOR_HALF_SIZE_M) -> list[int]:
    """Turn the infinite planes of a model the video draws into squares of `half_size` [m] that
    look the same: an infinite plane's texture repeats `texrepeat` times over 2 m, a finite
    one's over its side (unless `texuniform`). Only planes with a material of their own (or
    none) are changed; returns their ids. For drawing only: this changes the model."""
    planes = np.flatnonzero(
        (model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE)
        & ((model.geom_size[:, 0] <= 0) | (model.geom_size[:, 1] <= 0))
    )
    changed = []
    for geom in planes:
        mat = model.geom_matid[geom]
        if mat >= 0 and np.count_nonzero(model.geom_matid == mat) > 1:
            continue
        if mat >= 0 and not model.mat_texuniform[mat]:
            model.mat_texrepeat[mat] *= half_size
        model.geom_size[geom] = (half_size, half_size, half_size / 2.0)
        changed.append(int(geom))
    return changed


class FramePainter:
    """Draws the video's frames of given states on its own copy of the data.

    Args:
        model: The model to draw (its visual quality and off-screen buffer are set for the
            video: give the painter a model of its own).
        width: Frame width [px].
        height: Frame height [px].
        samples: Multisampling (`SAMPLES` by default).
        simplify: Draw boxes with `BOX_QUADS` and infinite floors as squares
            (`finite_floors`): a cheaper frame, all but the same.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int,
        height: int,
        samples: int = SAMPLES,
        simplify: bool = True,
    ):
        self.model = model
        self.size = (int(width), int(height))
        model.vis.quality.offsamples = int(samples)
        self._floors: dict[int, np.ndarray] = {}
        """The floors drawn as squares (`finite_floors`): their sizes are the painter's."""
        if simplify:
            model.vis.quality.numquads = BOX_QUADS
            self._floors = {g: model.geom_size[g].copy() for g in finite_floors(model)}
        vis = model.vis.global_
        vis.offwidth, vis.offheight = self.size
        self.data = mujoco.MjData(model)
        self.cam = view_camera(model)
        self._ghosts = ghosted_geoms(model)
        check_backend()
        self.renderer = mujoco.Renderer(model, height=self.size[1], width=self.size[0])

    def apply(self, state: FrameState) -> None:
        """Take on `state`: the model rows that changed, the pose of every body."""
        for name, (rows, values) in state.model_rows.items():
            getattr(self.model, name)[rows] = values
        for geom, size in self._floors.items():
            self.model.geom_size[geom] = size
        self.data.qpos[:] = state.qpos
        self.data.mocap_pos[:] = state.mocap_pos
        self.data.mocap_quat[:] = state.mocap_quat
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def paint(self, overlay: Overlay | None = None) -> np.ndarray:
        """The frame (height, width, 3) uint8 of the current state, annotated with `overlay`."""
        self.renderer.update_scene(self.data, camera=self.cam)
        ghost(self.renderer.scene, self._ghosts)
        frame = self.renderer.render().copy()
        if overlay is not None:
            pts = np.array([it[1:4] for it in overlay.items], dtype=float).reshape(-1, 3)
            annotate(frame, project(self.renderer.scene, pts, self.size), overlay)
        return frame

    def close(self) -> None:
        """Frees the renderer's GL context."""
        self.renderer.close()


def open_writer(path: Path, fps: float):
    """imageio's H.264 writer of the MP4 at `path`."""
    return imageio.get_writer(
        path,
        fps=fps,
        codec=ENCODER,
        quality=6,
        macro_block_size=8,
        pixelformat="yuv420p",
        ffmpeg_log_level="error",
        output_params=["-preset", ENCODER_PRESET],
    )


class VideoError(SortsimError):
    """The video process failed (not the encoder's writing: that is a refusal)."""


def _one_line(exc: BaseException) -> str:
    return " ".join(f"{type(exc).__name__}: {exc}".split())[:200]


_PIPE_BYTES = 1 << 20
"""The frame pipe's buffer: about 200 frames' states, so the episode runs on while the video
process catches up."""
_ABORT = "abort"


def _serve(inbox, outbox, model, tmp: str, fps: float, size, samples: int) -> None:
    """The video process: draw and encode every state received until told to finish.

    Replies ("done", frames, CPU s before the first frame, CPU s in all, the encoder's CPU s), or
    ("refused", refusal), ("encoder", line) or ("error", line).
    Drops the temporary MP4 when told to abort, on a failure, or when the episode's process
    is gone.
    """
    # Mesa's software renderer, on its own threads, would contend with the episode's process for
    # the cores; drawing in this process's one thread costs the least CPU time.
    os.environ.setdefault("LP_NUM_THREADS", "0")
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the episode's process finishes or aborts
    parent = os.getppid()
    tmp = Path(tmp)
    painter = writer = None
    try:
        painter = FramePainter(model, *size, samples=samples)
        try:
            writer = open_writer(tmp, fps)
        except (OSError, RuntimeError) as exc:  # the folder is gone, ffmpeg missing
            raise _EncoderFailure(exc) from None
        ready = time.process_time()
        frames = 0
        while True:
            try:
                message = inbox.recv()
            except EOFError:  # the episode's process is gone: nothing to finish
                message = _ABORT
            if message is None:
                break
            if message == _ABORT or os.getppid() != parent:
                raise _Abort
            state, overlay = message
            painter.apply(state)
            try:
                writer.append_data(painter.paint(overlay))
            except (OSError, RuntimeError) as exc:  # ffmpeg died: a full disk, a vanished folder
                raise _EncoderFailure(exc) from None
            frames += 1
        try:
            writer.close()
        except (OSError, RuntimeError) as exc:
            raise _EncoderFailure(exc) from None
        writer = None
        encoder = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = time.process_time()
        outbox.send(("done", frames, ready, cpu, encoder.ru_utime + encoder.ru_stime))
    except _Abort:
        pass
    except _EncoderFailure as exc:
        _reply(outbox, ("encoder", _one_line(exc.cause)))
    except RefusedInput as exc:
        _reply(outbox, ("refused", exc))
    except BaseException as exc:  # any failure: one line for the episode's process
        _reply(outbox, ("error", _one_line(exc)))
    finally:
        if writer is not None:
            with contextlib.suppress(Exception):
                writer.close()
            tmp.unlink(missing_ok=True)
        if painter is not None:
            painter.close()


class _Abort(Exception):
    """The episode was aborted or its process is gone."""


class _EncoderFailure(Exception):
    def __init__(self, cause: BaseException):
        super().__init__(str(cause))
        self.cause = cause


def _reply(outbox, message) -> None:
    with contextlib.suppress(OSError):
        outbox.send(message)


class VideoRecorder:
    """Sends a frame's state every 1/fps of simulated time to the video process (see the module
    docstring), which writes the MP4.

    Args:
        model: The compiled cell (copied into the video process as it is now; later changes of
            `MODEL_FIELDS` follow with the frames).
        path: Final MP4 path (written through a temporary file in the same folder).
        fps: Frames per simulated second (also the file's playback rate: real-time video).
        width: Frame width [px].
        height: Frame height [px].
        samples: Multisampling of the renders.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        path: Path,
        fps: float,
        width: int,
        height: int,
        samples: int = SAMPLES,
    ):
        self.model = model
        self.path = Path(path)
        self.fps = float(fps)
        self.size = (int(width), int(height))
        self.frames = 0
        self.stats: dict[str, float] = {}
        """After `close`: frames, the video process's CPU time before the first frame and for
        the frames (render, overlay, handing over to the encoder), the encoder's [s]."""
        self._next_t = 0.0
        self._watch = ModelWatch(model)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = temporary_path(self.path, ".mp4")
        context = multiprocessing.get_context("spawn")
        inbox, self._send = context.Pipe(duplex=False)
        self._results, outbox = context.Pipe(duplex=False)
        with contextlib.suppress(AttributeError, OSError):
            fcntl.fcntl(self._send.fileno(), fcntl.F_SETPIPE_SZ, _PIPE_BYTES)
        self._process = context.Process(
            target=_serve,
            args=(inbox, outbox, model, str(self._tmp), self.fps, self.size, int(samples)),
            name="sortsim-video",
            daemon=True,
        )
        self._process.start()
        inbox.close()
        outbox.close()

    @property
    def next_frame_time(self) -> float:
        """Sim time of the next frame [s]."""
        return self._next_t

    def due(self, t: float) -> bool:
        """Whether a frame is due at simulated time `t` [s]."""
        return t + 1e-9 >= self._next_t

    def capture(self, data: mujoco.MjData, overlay: Overlay) -> None:
        """Send the current state and `overlay` as the next frame."""
        if self._results.poll():  # the video process stopped early: say why
            self._raise(self._results.recv())
        try:
            self._send.send((frame_state(self.model, data, self._watch), overlay))
        except OSError:
            self._raise(self._reply())
        self.frames += 1
        self._next_t = self.frames / self.fps

    def _reply(self):
        """The video process's reply, or None when it ended without one."""
        try:
            return self._results.recv()
        except (EOFError, OSError):
            return None

    def _raise(self, reply) -> None:
        self._stop()
        Path(self._tmp).unlink(missing_ok=True)
        if reply is None:
            code = self._process.exitcode
            raise VideoError(f"the video process ended unexpectedly (exit code {code})")
        kind, detail = reply[0], reply[1]
        if kind == "refused":
            raise detail
        if kind == "encoder":
            raise InvalidInput("video", "a place the video encoder can write", detail, self.path)
        raise VideoError(f"video process: {detail}")

    def _stop(self, timeout: float = 10.0) -> None:
        """Wait for the video process to end (ended by force after `timeout` s)."""
        self._process.join(timeout)
        if self._process.is_alive():
            self._process.kill()
            self._process.join()
        for conn in (self._send, self._results):
            conn.close()

    def close(self) -> Path:
        """Wait for the video process to encode every frame; move the MP4 into place."""
        try:
            self._send.send(None)
        except OSError:
            pass
        reply = self._reply()
        if reply is None or reply[0] != "done":
            self._raise(reply)
        self._stop()
        _, frames, ready, cpu, encoder = reply
        self.stats = {
            "frames": frames,
            "startup_cpu_s": ready,
            "frames_cpu_s": cpu - ready,
            "encoder_cpu_s": encoder,
        }
        os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Drop the partial video (the episode failed; a failing video is not reported again)."""
        with contextlib.suppress(OSError):
            self._send.send(_ABORT)
        self._stop()
        Path(self._tmp).unlink(missing_ok=True)


def overlay_of(episode, t: float) -> Overlay:
    """The annotations of an episode's frame at sim time `t` [s]."""
    items = []
    tracks = episode.tracker.tracks()
    under_way = [s.current_pick for s in episode.stations if s.current_pick is not None]
    tracks.extend(under_way)
    for tr in tracks:
        cls = tr.predicted_class
        items.append((tr.track_id, tr.x_at(t, episode.speed), tr.y, 0.03, cls, tr.probs[cls - 1]))
    m = episode.metrics
    short, colours = class_labels(m.materials)
    counters = [
        f"t {t:5.1f} s  x{episode.config.speed_factor:g}  {episode.config.planner}  "
        f"{episode.config.perception}",
        f"entered {m.n_entered}  picked {m.n_picked}  missed {len(m.missed)}",
        f"profit {m.profit:.2f} EUR",
        "purity " + purity_text(m.binned, short),
    ]
    pick = None if episode.current_pick is None else episode.current_pick.track_id
    picks = tuple(track.track_id for track in under_way)
    return Overlay(
        items=items,
        next_pick=pick,
        counters=counters,
        short=short,
        colours=colours,
        next_picks=picks,
    )


def purity_text(binned: dict[int, tuple[int, int]], short: dict[int, str] = CLASS_SHORT) -> str:
    """'PAP 1.00  PL 0.95  AL -': each bin's share of items of its own class so far ('-' for
    an empty bin), from {item: (true class, bin class)}; `short`: each bin's label."""
    parts = []
    for cls, label in short.items():
        in_bin = [t for t, b in binned.values() if b == cls]
        share = f"{sum(t == cls for t in in_bin) / len(in_bin):.2f}" if in_bin else "-"
        parts.append(f"{label} {share}")
    return "  ".join(parts)
