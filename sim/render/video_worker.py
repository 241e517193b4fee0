"""The video process's side: the tasks a `VideoRecorder`'s one-worker process pool runs.

The pool starts its worker with `start` (the model, the temporary MP4, the rate and size), which
keeps them in this module's state. The recorder then submits `open_video` (the painter and the
writer), one `draw` per frame (in order: one worker takes its tasks first in, first out) and
`finish` (the MP4 complete) or `drop` (the episode was aborted). A task's failure reaches the
episode's process through its future as an exception that pickles: `EncoderFailure` (the
encoder cannot write), a refusal, or `VideoError` with the failure in one line; the worker then
drops the temporary MP4 and every later task raises the same failure.

The temporary MP4 never outlives the worker unfinished: it is dropped when the worker ends
before `finish` (a pool shut down early) and, within `PARENT_POLL_S`, when the episode's process
is gone (killed: a watchdog thread sees the worker's parent change, drops the MP4 and ends the
worker).
"""

from __future__ import annotations

import contextlib
import os
import resource
import signal
import threading
import time
from dataclasses import dataclass
from multiprocessing import util
from pathlib import Path
from typing import Any

import mujoco

from sim.errors import RefusedInput
from sim.render.encoder import EncoderFailure, VideoError, one_line, open_writer
from sim.render.labels import Overlay
from sim.render.painter import FramePainter, FrameState

PARENT_POLL_S = 0.2
"""How often the watchdog looks whether the episode's process is still there [s]."""
LOCK_TIMEOUT_S = 5.0
"""Longest wait of the watchdog for a frame being drawn before it drops the MP4 anyway [s]."""


@dataclass
class _Video:
    """The worker's state: what `start` was given and what the tasks made of it."""

    model: mujoco.MjModel
    tmp: Path
    fps: float
    size: tuple[int, int]
    samples: int
    painter: FramePainter | None = None
    writer: Any | None = None  # imageio's writer (`open_writer`)
    frames: int = 0
    ready_cpu_s: float = 0.0
    finished: bool = False
    failure: BaseException | None = None


_video: _Video | None = None
_lock = threading.Lock()
"""Held by a task and by the watchdog: the MP4 is never dropped halfway through a frame."""


def start(model: mujoco.MjModel, tmp: str, fps: float, size, samples: int) -> None:
    """The pool's initializer: keep the video's settings; watch for the parent's end.

    Args:
        model: The compiled cell as the video starts.
        tmp: The temporary MP4's path.
        fps: Frames per second of playback [1/s].
        size: Frame (width, height) [px].
        samples: Multisampling of the renders.
    """
    global _video
    # Mesa's software renderer, on its own threads, would contend with the episode's process for
    # the cores; drawing in this process's one thread costs the least CPU time.
    os.environ.setdefault("LP_NUM_THREADS", "0")
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the episode's process finishes or aborts
    _video = _Video(model, Path(tmp), float(fps), (int(size[0]), int(size[1])), int(samples))
    util.Finalize(None, _drop_unfinished, exitpriority=10)
    watchdog = threading.Thread(
        target=_watch_parent, args=(os.getppid(),), name="video-watchdog", daemon=True
    )
    watchdog.start()


@contextlib.contextmanager
def _task():
    """Run a task on the video's state; on a failure drop the MP4 and keep the failure."""
    with _lock:
        video = _video
        if video.failure is not None:
            raise video.failure
        try:
            yield video
        except (EncoderFailure, RefusedInput) as exc:
            video.failure = exc
            _drop(video)
            raise
        except BaseException as exc:  # any failure: one line for the episode's process
            video.failure = VideoError(f"video process: {one_line(exc)}")
            _drop(video)
            raise video.failure from None


def open_video() -> int:
    """Make the painter and open the writer; returns this process's id."""
    with _task() as video:
        width, height = video.size
        video.painter = FramePainter(video.model, width, height, samples=video.samples)
        try:
            video.writer = open_writer(video.tmp, video.fps)
        except (OSError, RuntimeError) as exc:  # the folder is gone, ffmpeg missing
            raise EncoderFailure(one_line(exc)) from None
        video.ready_cpu_s = time.process_time()
    return os.getpid()


def draw(state: FrameState, overlay: Overlay | None) -> None:
    """Draw the frame of `state`, `overlay` over it, and hand it to the encoder."""
    with _task() as video:
        video.painter.apply(state)
        frame = video.painter.paint(overlay)
        try:
            video.writer.append_data(frame)
        except (OSError, RuntimeError) as exc:  # ffmpeg died: a full disk, a vanished folder
            raise EncoderFailure(one_line(exc)) from None
        video.frames += 1


def finish() -> dict[str, float]:
    """Encode every frame drawn and close the MP4 (the episode's process renames it).

    Returns:
        frames; the CPU time of this process before the first frame (`startup_cpu_s`) and for
        the frames (`frames_cpu_s`: render, overlay, handing over to the encoder); the
        encoder's (`encoder_cpu_s`) [s].
    """
    with _task() as video:
        try:
            video.writer.close()
        except (OSError, RuntimeError) as exc:
            raise EncoderFailure(one_line(exc)) from None
        video.writer = None
        video.finished = True
        encoder = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = time.process_time()
        video.painter.close()
        video.painter = None
        return {
            "frames": video.frames,
            "startup_cpu_s": video.ready_cpu_s,
            "frames_cpu_s": cpu - video.ready_cpu_s,
            "encoder_cpu_s": encoder.ru_utime + encoder.ru_stime,
        }


def drop() -> None:
    """Drop the partial MP4 (the episode was aborted)."""
    with _lock:
        _drop(_video)


def _drop(video: _Video | None, finished_too: bool = True) -> None:
    """Close the writer and the painter; remove the temporary MP4 (unless `finished_too` is
    False and it was finished)."""
    if video is None:
        return
    if video.writer is not None:
        with contextlib.suppress(Exception):
            video.writer.close()
        video.writer = None
    if finished_too or not video.finished:
        video.tmp.unlink(missing_ok=True)
    if video.painter is not None:
        with contextlib.suppress(Exception):
            video.painter.close()
        video.painter = None


def _drop_unfinished() -> None:
    """At the worker's exit: an MP4 not finished is dropped."""
    with _lock:
        _drop(_video, finished_too=False)


def _watch_parent(parent: int) -> None:
    """End the worker, the MP4 dropped, once the episode's process `parent` is gone."""
    while os.getppid() == parent:
        time.sleep(PARENT_POLL_S)
    if _lock.acquire(timeout=LOCK_TIMEOUT_S):
        _drop(_video)
    elif _video is not None:
        _video.tmp.unlink(missing_ok=True)
    os._exit(0)
