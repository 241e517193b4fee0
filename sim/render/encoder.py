"""The video's H.264 encoder: proving it works here, opening a writer, its failures.

The MP4 is written by imageio-ffmpeg's ffmpeg with libx264. `check_encoder` proves, before an
episode runs, that the encoder works here (one black frame encoded to nothing) and refuses in one
line when it does not. While a video is written, an encoder that cannot write (a full disk, a
vanished folder) is an `EncoderFailure`, which the episode's process turns into a refusal (exit
code 2); any other failure of the video process is a `VideoError` (exit code 1).
"""

from __future__ import annotations

import functools
import subprocess
from pathlib import Path

import imageio.v2 as imageio

from sim.errors import InvalidInput, SortsimError

ENCODER = "libx264"
"""The H.264 encoder of imageio-ffmpeg's ffmpeg that writes the MP4s."""
ENCODER_PRESET = "veryfast"
"""x264's speed preset: 3.6 ms a 640x360 frame against 8.3 ms for its default (medium), for a
file 5 % smaller at the same quality setting (crf 20) on the headline episode's frames."""


class VideoError(SortsimError):
    """The video process failed (not the encoder's writing: that is a refusal)."""


class EncoderFailure(Exception):
    """The encoder could not open or write the MP4 (a full disk, a vanished folder, no ffmpeg);
    its message is one line."""

    def __init__(self, line: str):
        super().__init__(line)
        self.line = line


def one_line(exc: BaseException) -> str:
    """An exception as one line of at most 200 characters: 'Type: message', its whitespace
    collapsed."""
    return " ".join(f"{type(exc).__name__}: {exc}".split())[:200]


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
    """Refuse in one line naming `field`, before any episode runs, when ffmpeg cannot write
    H.264 here.

    Raises:
        InvalidInput: imageio-ffmpeg's ffmpeg is missing or has no working libx264.
    """
    failure = _encoder_failure()
    if failure is not None:
        allowed = f"a video the encoder can write (imageio-ffmpeg's ffmpeg with {ENCODER})"
        raise InvalidInput(field, allowed, " ".join(failure.split())[:160])


def open_writer(path: Path, fps: float):
    """imageio's H.264 writer of an MP4.

    Args:
        path: The file to write (ffmpeg opens it at the first frame).
        fps: Playback rate [frames/s].

    Returns:
        The writer (`append_data(frame)`, `close()`).
    """
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
