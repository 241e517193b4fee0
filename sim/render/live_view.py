"""An episode shown live in MuJoCo's interactive viewer (`mujoco.viewer.launch_passive`).

`LiveView` takes the place of the episode's video recorder, a `sim.render.sink.FrameSink` (the
loop hands it a frame at fixed steps of simulated time, `due` / `next_frame_time` / `capture`):
at each frame it draws the tracked items (a sphere coloured by predicted class, the next pick's
larger, labelled as in the video) and the counters into the viewer, calls `sync()` and sleeps
until the wall clock has caught up with the simulated time divided by the wanted real-time
factor (0: no sleep, as fast as the machine steps). A machine too slow for the pace shows the
episode as fast as it can and does not rush to catch up afterwards. Closing the window stops
the episode (`ViewerClosed`).

The viewer draws with GLFW in a thread of its own and needs a display: an X server (`DISPLAY`;
a desktop, or a virtual one such as Xvfb) on Linux, `mjpython` on macOS. `check_display`
refuses, in one line and before any work, an environment without one. The episode's own
off-screen renders (the belt camera) keep the back-end `MUJOCO_GL` names (EGL or OSMesa) in
the main thread: the two contexts live side by side in one process.
"""

from __future__ import annotations

import os
import sys
import threading
import time

import mujoco
import numpy as np

from sim.cell.rendering import quiet_stderr
from sim.errors import InvalidInput
from sim.render.labels import Overlay

FRAME_RATE_HZ = 30.0
"""Viewer updates per wall-clock second at the wanted pace."""
MAX_LAG_S = 0.25
"""Behind the pace by more than this [s of wall time], the pace starts again from now (a slow
stretch is not made up by a burst)."""
MAX_REAL_TIME_FACTOR = 1000.0
"""Fastest pace that may be asked (simulated seconds per wall-clock second)."""
CLOSE_TIMEOUT_S = 5.0
"""Longest wait for the viewer's window to close [s]."""
ITEM_RADIUS_M = 0.02
"""Radius of a tracked item's sphere [m]; the next pick's is twice as large."""
WHERE = "the environment"
# The window's first view (the mouse moves it): the whole belt from the side of the paper bin,
# low enough to see the belt between the robot's cage beams (which the viewer cannot ghost).
LOOKAT = (-0.4, 0.0, 0.25)
DISTANCE = 3.6
AZIMUTH = 120.0
ELEVATION = -24.0


class ViewerClosed(Exception):
    """The viewer's window was closed while the episode ran.

    Attributes:
        status: The counters the window showed last (time, entered, picked, missed, profit).
    """

    def __init__(self, status: str):
        super().__init__(status)
        self.status = status


def check_display() -> None:
    """Refuse, in one line, an environment where MuJoCo's viewer cannot open a window.

    Raises:
        InvalidInput: no `DISPLAY` (Linux and other X11 systems), a display GLFW cannot open,
            the `glfw` package or its library missing, or macOS outside `mjpython`.
    """
    if sys.platform != "darwin":
        display = os.environ.get("DISPLAY", "").strip()
        if not display:
            allowed = (
                "an X display for the viewer's window: run it in a desktop session, or under "
                "a virtual one (xvfb-run -s '-screen 0 1280x1024x24' sortsim view ...)"
            )
            raise InvalidInput("DISPLAY", allowed, "unset", WHERE)
    try:
        with quiet_stderr():
            import mujoco.viewer
    except (ImportError, RuntimeError) as exc:
        reason = " ".join(str(exc).split())[:120]
        allowed = "the glfw package and its library (pip install glfw)"
        raise InvalidInput("glfw", allowed, reason, WHERE) from None
    if sys.platform == "darwin":
        if getattr(mujoco.viewer, "_MJPYTHON", None) is None:
            allowed = "mjpython on macOS (mjpython -m sim.cli view ...)"
            raise InvalidInput("python", allowed, sys.executable, WHERE)
        return
    import glfw

    with quiet_stderr():
        opened = bool(glfw.init())
        if opened:
            glfw.terminate()  # the viewer's thread initialises GLFW again for itself
    if not opened:
        allowed = "an X display GLFW can open (is the X server running? xdpyinfo tells)"
        raise InvalidInput("DISPLAY", allowed, display, WHERE)


OFFSCREEN_BACKENDS = ("egl", "osmesa")
"""MUJOCO_GL values that keep the episode's own renders (the belt camera) off GLFW, which the
viewer's window uses from a thread of its own (GLFW is not made for two threads)."""


def check_camera_beside_viewer() -> None:
    """Refuse, in one line, camera perception beside the viewer without an off-screen back-end.

    Raises:
        InvalidInput: MUJOCO_GL is not egl or osmesa.
    """
    from sim.cell.rendering import given_backend

    value = given_backend()
    if value.strip().lower() not in OFFSCREEN_BACKENDS:
        allowed = (
            "egl or osmesa for the camera's renders beside the viewer's window, which uses GLFW: "
            "set MUJOCO_GL=egl PYOPENGL_PLATFORM=egl (or osmesa), or use --perception truth"
        )
        raise InvalidInput("MUJOCO_GL", allowed, value, WHERE)


def check_real_time_factor(value: float, field: str = "--real-time-factor") -> float:
    """`value` if it is a pace the view can keep (0: as fast as it runs), else refused."""
    ok = isinstance(value, int | float) and 0.0 <= value <= MAX_REAL_TIME_FACTOR
    if not ok or value != value:
        allowed = f"0..{MAX_REAL_TIME_FACTOR:g} simulated s per wall s (0: as fast as it runs)"
        raise InvalidInput(field, allowed, value)
    return float(value)


class LiveView:
    """MuJoCo's viewer on a cell's model and data, fed by the episode's loop as a video is (a
    `sim.render.sink.FrameSink`).

    Args:
        model: The compiled cell (the episode's).
        data: Its data, stepped by the episode.
        real_time_factor: Simulated seconds per wall-clock second to show (1: real time;
            0: no pacing, as fast as the machine steps).
        panels: Show the viewer's left and right panels (their reset, keyframe and slider
            controls write into the running episode's state).
        frame_rate_hz: Viewer updates per wall-clock second at that pace.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        real_time_factor: float = 1.0,
        panels: bool = False,
        frame_rate_hz: float = FRAME_RATE_HZ,
    ):
        import mujoco.viewer

        self.real_time_factor = check_real_time_factor(real_time_factor)
        pace = self.real_time_factor if self.real_time_factor > 0 else 1.0
        self.period_s = max(pace / float(frame_rate_hz), float(model.opt.timestep))
        """Simulated time between two viewer updates [s]."""
        before = set(threading.enumerate())
        self.handle = mujoco.viewer.launch_passive(
            model, data, show_left_ui=panels, show_right_ui=panels
        )
        # The viewer's threads (its window's and its loader's), joined when it closes: a
        # window still drawing while the interpreter ends GLFW fails with an X error.
        self._threads = [t for t in threading.enumerate() if t not in before]
        with self.handle.lock():
            cam = self.handle.cam
            cam.lookat[:] = LOOKAT
            cam.distance, cam.azimuth, cam.elevation = DISTANCE, AZIMUTH, ELEVATION
        self._texts = _TextPoster(self.handle)
        self.frames = 0
        self.status = ""
        self._next_t = 0.0
        self._anchor: tuple[float, float] | None = None  # (wall clock, sim time) [s]

    @property
    def next_frame_time(self) -> float:
        """Sim time of the next viewer update [s]."""
        return self._next_t

    def due(self, t: float) -> bool:
        """Whether a viewer update is due at simulated time `t` [s]."""
        return t + 1e-9 >= self._next_t

    def capture(self, data: mujoco.MjData, overlay: Overlay) -> None:
        """Show the current state with `overlay`, then wait for the pace.

        Raises:
            ViewerClosed: the window was closed.
        """
        self.status = "; ".join(" ".join(line.split()) for line in overlay.counters[:3])
        if not self.handle.is_running():
            raise ViewerClosed(self.status)
        with self.handle.lock():
            self._draw_items(overlay)
        self._texts.post("\n".join(overlay.counters))
        self.handle.sync()
        self.frames += 1
        t = float(data.time)
        self._next_t = t + self.period_s
        self._pace(t)

    def _draw_items(self, overlay: Overlay) -> None:
        """The tracked items as spheres in the viewer's extra scene (lock held)."""
        scene = self.handle.user_scn
        if scene is None:
            return
        scene.ngeom = 0
        for track_id, x, y, z, cls, prob in overlay.items[: scene.maxgeom]:
            rgba = np.array([*overlay.colours.get(cls, (200, 200, 200)), 255], dtype=float) / 255
            big = track_id == overlay.next_pick or track_id in overlay.next_picks
            radius = ITEM_RADIUS_M * (2.0 if big else 1.0)
            geom = scene.geoms[scene.ngeom]
            mujoco.mjv_initGeom(
                geom,
                mujoco.mjtGeom.mjGEOM_SPHERE,
                np.array([radius, 0.0, 0.0]),
                np.array([x, y, z + radius]),
                np.eye(3).ravel(),
                rgba.astype(np.float32),
            )
            name = overlay.short.get(cls, "?")
            geom.label = name if prob >= 0.995 else f"{name} {prob:.0%}"
            scene.ngeom += 1

    def _pace(self, t: float) -> None:
        """Sleep until the wall clock reaches simulated time `t` at the wanted pace."""
        if self.real_time_factor <= 0:
            return
        now = time.perf_counter()
        if self._anchor is None:
            self._anchor = (now, t)
            return
        wall0, sim0 = self._anchor
        target = wall0 + (t - sim0) / self.real_time_factor
        if target > now:
            time.sleep(target - now)
        elif now - target > MAX_LAG_S:
            self._anchor = (now, t)

    def close(self) -> None:
        """Close the window (the episode ended) and wait for the viewer's threads to end."""
        self._texts.stop()
        self.handle.close()
        for thread in self._threads:
            thread.join(timeout=CLOSE_TIMEOUT_S)

    def abort(self) -> None:
        """Close the window (the episode stopped early)."""
        self.close()


class _TextPoster:
    """Posts the counters to the viewer from a thread of its own, the latest text only.

    The viewer's `set_texts` waits for the window's next redraw (tens of milliseconds; more
    with software OpenGL), which the episode's loop should not wait for at every update.
    Nothing is posted where the viewer has no `set_texts` (MuJoCo before 3.3.3).
    """

    def __init__(self, handle):
        self._set = getattr(handle, "set_texts", None)
        self._latest: str | None = None
        self._shown: str | None = None
        self._stopped = False
        self._wake = threading.Condition()
        self._thread = threading.Thread(target=self._run, name="viewer-texts", daemon=True)
        if self._set is not None:
            self._thread.start()

    def post(self, text: str) -> None:
        """Show `text` at the window's top left corner as soon as the viewer takes it."""
        with self._wake:
            self._latest = text
            self._wake.notify()

    def _run(self) -> None:
        font, corner = mujoco.mjtFontScale.mjFONTSCALE_150, mujoco.mjtGridPos.mjGRID_TOPLEFT
        while True:
            with self._wake:
                self._wake.wait_for(lambda: self._stopped or self._latest != self._shown)
                if self._stopped:
                    return
                text = self._shown = self._latest
            self._set((font, corner, text, ""))

    def stop(self) -> None:
        """Post nothing more (waits briefly for a post under way)."""
        with self._wake:
            self._stopped = True
            self._wake.notify()
        if self._thread.is_alive():
            self._thread.join(timeout=1.0)
