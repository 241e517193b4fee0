"""The one interface the episode's loop hands its frames to: `FrameSink`.

The loop asks a sink, after each step, whether a frame is `due` at the simulated time, and if so
hands it the data and the frame's `Overlay` (`capture`); it plans its steps so that none passes
`next_frame_time`. When the episode ends the loop calls `close` (finish: the MP4 written, the
window closed) or, when it failed or was stopped, `abort` (drop what is partial).

Two sinks exist: `sim.render.video.VideoRecorder` (an MP4 written by a process of its own) and
`sim.render.live_view.LiveView` (MuJoCo's viewer, paced to a wanted real-time factor).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import mujoco

from sim.render.labels import Overlay


@runtime_checkable
class FrameSink(Protocol):
    """What takes the episode's frames at fixed steps of simulated time."""

    @property
    def next_frame_time(self) -> float:
        """Simulated time of the next frame [s]."""
        ...

    def due(self, t: float) -> bool:
        """Whether a frame is due at simulated time `t` [s]: at or after `next_frame_time`."""
        ...

    def capture(self, data: mujoco.MjData, overlay: Overlay) -> None:
        """Take the frame of the current state.

        Args:
            data: The episode's data now (read during the call only).
            overlay: The frame's annotations.
        """
        ...

    def close(self) -> object:
        """Finish: every frame taken is shown or written (the episode ended)."""
        ...

    def abort(self) -> None:
        """Drop what is partial (the episode failed or was stopped)."""
        ...
