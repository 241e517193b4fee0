"""The episode's video: the cell from a free camera over the belt with overlays, as H.264 MP4.

Frames are rendered off-screen at a small size (default 640x360) at a fixed rate of simulated
time, from a view over the whole belt (the camera box to the discharge), the robot and all three
bins, the robot's cage and the camera box drawn see-through (`sim.render.view`); then annotated
with OpenCV: each tracked item's predicted class next to it (where the cell believes it is;
labels never overlap, a crowded item keeps its dot only), the chosen next pick boxed, the
pick/miss counters, the profit and each bin's purity so far (`sim.render.labels`).

The frames are rendered, annotated and encoded in a process of their own: `VideoRecorder` runs a
`ProcessPoolExecutor` of one spawned worker (`sim.render.video_worker`), so the episode's
process only submits, per frame, what the frame is drawn from (`sim.render.painter.FrameState`):
the joint positions, the mocap poses, the rows of the model fields the simulation changed since
the last frame and the overlay. The worker holds its own copy of the model and data and draws
with `FramePainter`; one worker runs the frames in the order submitted. At most
`MAX_FRAMES_IN_FLIGHT` frames wait for it: beyond that the episode waits for the oldest.

The MP4 is written by imageio-ffmpeg (`sim.render.encoder`) to a temporary file and renamed
into place when the episode ends, so a killed run leaves no half-written video: the worker drops
it when the episode's process goes away, and the temporary follows `sim.paths.temporary_path`
(named after the episode's process), so the next run removes any leftover. A failure in the
video process reaches the episode's process through the frames' futures as one line: a refusal
(exit code 2) when the encoder cannot write, `VideoError` (exit code 1) otherwise.
"""

from __future__ import annotations

import collections
import contextlib
import multiprocessing
import os
import threading
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import NoReturn

import mujoco

from sim.errors import InvalidInput, RefusedInput
from sim.paths import temporary_path
from sim.render import video_worker
from sim.render.encoder import EncoderFailure, VideoError, one_line
from sim.render.labels import Overlay
from sim.render.painter import SAMPLES, ModelWatch, frame_state

MAX_FRAMES_IN_FLIGHT = 32
"""Frames submitted to the video process and not yet drawn, at most: beyond, `capture` waits
for the oldest (3.2 s of simulated time at 10 frames/s; about 0.4 s of the worker's time at
640x360, 12 ms a frame measured)."""
STOP_TIMEOUT_S = 10.0
"""Longest wait for the video process to end once told [s]; then it is killed."""


class VideoRecorder:
    """Submits a frame's state every 1/fps of simulated time to the video process (see the
    module docstring), which writes the MP4. A `sim.render.sink.FrameSink`.

    Args:
        model: The compiled cell (copied into the video process as it is now; later changes of
            the model's drawn fields follow with the frames).
        path: Final MP4 path (written through a temporary file in the same folder).
        fps: Frames per simulated second (also the file's playback rate: real-time video)
            [1/s].
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
        self._pool = ProcessPoolExecutor(
            max_workers=1,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=video_worker.start,
            initargs=(model, str(self._tmp), self.fps, self.size, int(samples)),
        )
        self._in_flight: collections.deque[Future] = collections.deque()
        self._in_flight.append(self._submit(video_worker.open_video))
        # The pool starts its worker at the first submit; its process, to end it by force and
        # to name its exit code.
        self._process = next(iter((getattr(self._pool, "_processes", None) or {}).values()), None)

    @property
    def next_frame_time(self) -> float:
        """Sim time of the next frame [s]."""
        return self._next_t

    def due(self, t: float) -> bool:
        """Whether a frame is due at simulated time `t` [s]: at or after the next frame's time."""
        return t + 1e-9 >= self._next_t

    def capture(self, data: mujoco.MjData, overlay: Overlay) -> None:
        """Submit the current state and `overlay` as the next frame.

        Raises:
            InvalidInput: The encoder could not write (the video process stopped early).
            VideoError: The video process failed otherwise.
        """
        self._collect(keep=MAX_FRAMES_IN_FLIGHT - 1)
        state = frame_state(self.model, data, self._watch)
        self._in_flight.append(self._submit(video_worker.draw, state, overlay))
        self.frames += 1
        self._next_t = self.frames / self.fps

    def close(self) -> Path:
        """Wait for the video process to encode every frame; move the MP4 into place (its path
        is returned).

        Raises:
            InvalidInput: The encoder could not write.
            VideoError: The video process failed otherwise.
        """
        finished = self._submit(video_worker.finish)
        self._collect(keep=0)
        self.stats = self._result(finished)
        self._stop()
        os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Drop the partial video (the episode failed; a failing video is not reported again)."""
        for future in self._in_flight:
            future.cancel()  # the frames not yet handed to the worker
        self._in_flight.clear()
        with contextlib.suppress(BrokenProcessPool, RuntimeError):
            self._pool.submit(video_worker.drop)
        self._stop(cancel=False)
        self._tmp.unlink(missing_ok=True)

    def _submit(self, fn, *args) -> Future:
        try:
            return self._pool.submit(fn, *args)
        except BrokenProcessPool as exc:
            self._fail(exc)

    def _collect(self, keep: int) -> None:
        """Take the results of the frames done, oldest first, and of the oldest until at most
        `keep` are in flight; the first failure is raised."""
        while self._in_flight and (self._in_flight[0].done() or len(self._in_flight) > keep):
            self._result(self._in_flight.popleft())

    def _result(self, future: Future):
        try:
            return future.result()
        except BaseException as exc:
            self._fail(exc)

    def _fail(self, exc: BaseException) -> NoReturn:
        """End the video process, drop the MP4, and raise `exc` as the episode's failure."""
        self._stop()
        self._tmp.unlink(missing_ok=True)
        if isinstance(exc, EncoderFailure):
            raise InvalidInput(
                "video", "a place the video encoder can write", exc.line, str(self.path)
            ) from None
        if isinstance(exc, RefusedInput | VideoError):
            raise exc from None
        if isinstance(exc, BrokenProcessPool):
            code = None if self._process is None else self._process.exitcode
            raise VideoError(f"the video process ended unexpectedly (exit code {code})") from None
        raise VideoError(f"video process: {one_line(exc)}") from None

    def _stop(self, cancel: bool = True) -> None:
        """Shut the pool down and wait for the video process to end (ended by force after
        `STOP_TIMEOUT_S`); `cancel`: the tasks not yet handed to the worker are dropped."""
        self._in_flight.clear()
        killer = threading.Timer(STOP_TIMEOUT_S, self._kill)
        killer.daemon = True
        killer.start()
        try:
            self._pool.shutdown(wait=True, cancel_futures=cancel)
        finally:
            killer.cancel()

    def _kill(self) -> None:
        """End the video process by force (it did not end when told)."""
        if self._process is not None:
            with contextlib.suppress(OSError):
                self._process.kill()
