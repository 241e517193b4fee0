"""`sortsim run`: one closed-loop episode of the sorting cell.

Writes `<out>/episodes.csv`, `<out>/picks.csv`, `<out>/timeline.csv` (`sim.results.timeline`; picks
and timeline streamed while the episode runs: Ctrl-C leaves them in `picks.interrupted.csv` and
`timeline.interrupted.csv`) and, with `--video`, the MP4; prints a progress line on stderr while it
runs and a one-screen summary at the end. Everything is checked before anything is simulated
(`preflight`): the config (TOML and options), the output folder and video path (creatable,
writable, not a folder), and for camera perception or a video the rendering back-end, the camera's
calibration, the cached stripe HMMs and the video encoder. A refused value exits with code 2 and
one line naming it, and nothing is written. Temporaries a killed run left behind are removed when
the next run starts.

The folder is locked while the run uses it (`sim.results.locks.FolderLock`): a second run or sweep
into it is refused in one line (exit 2) before any work, and a sweep's folder is refused too (a run
would replace its rows). The files land together (`write_run`: written to temporaries, renamed into
place, the manifest last); when they cannot be written (a full disk) their texts are kept as JSON
elsewhere (`sim.results.outputs.keep_unwritten`), one line says where, and the exit code is 1. A
video that fails (its disk full, its encoder gone) never costs the CSVs: the episode runs on
without it (`KeptVideo`), the CSVs are written, one line says the video failed, and the exit code
is 1.
"""

from __future__ import annotations

import argparse
import math
import shutil
import struct
import sys
from pathlib import Path

from sim.config.options import add_options, load_keywords

SWEEP_FILE = "sweep.json"
"""`sim.experiments.sweep_runner.IDENTITY_FILE`: what marks a sweep's folder."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim run`: the episode's (`add_episode_arguments`), the video, the folder."""
    add_episode_arguments(parser)
    parser.add_argument(
        "--video",
        default=None,
        help="write an MP4 of the episode to this path (.mp4; its size and frame rate: the "
        "config's [video], 640 x 360 at 10 frames/s by default)",
    )
    parser.add_argument("--out", type=Path, default=Path("runs/latest"), help="output folder")


def add_episode_arguments(parser: argparse.ArgumentParser) -> None:
    """The options that make the episode's config (`load_config`), shared by `sortsim view`:
    `--config` and the config's own (`sim.config.options`)."""
    parser.add_argument(
        "--config",
        type=Path,
        help="TOML file, or a run folder's manifest.json to repeat that run; command-line "
        "options override it",
    )
    add_options(parser)


class Progress:
    """A one-line progress bar on stderr (redrawn in place on a terminal, else every 10 %)
    with the wall time left at the pace so far (`eta`)."""

    def __init__(self, stream=None, width: int = 30, clock=None):
        import time

        # stderr as it is now (not when this module was imported: a test harness swaps it)
        self.stream = sys.stderr if stream is None else stream
        self.width = width
        self.tty = self.stream.isatty()
        self._last_decile = -1
        self.clock = time.monotonic if clock is None else clock
        self.start = self.clock()

    def __call__(self, fraction: float, text: str) -> None:
        fraction = min(max(fraction, 0.0), 1.0)
        left = eta(self.clock() - self.start, fraction)
        if self.tty:
            filled = int(round(fraction * self.width))
            bar = "#" * filled + "." * (self.width - filled)
            self.stream.write(f"\r[{bar}] {fraction:4.0%} {left} {text}\x1b[K")
            self.stream.flush()
        elif int(fraction * 10) > self._last_decile:
            self._last_decile = int(fraction * 10)
            self.stream.write(f"{fraction:4.0%} {left} {text}\n")
            self.stream.flush()

    def done(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


def eta(elapsed_s: float, fraction: float) -> str:
    """'ETA h:mm:ss': the wall time left when the rest goes at the pace of `elapsed_s` [s]
    for `fraction` done ('ETA -' before there is a pace)."""
    if fraction <= 0.0 or elapsed_s <= 0.0:
        return "ETA -"
    left = round(elapsed_s * (1.0 - fraction) / fraction)
    return f"ETA {left // 3600}:{left // 60 % 60:02d}:{left % 60:02d}"


def _by_class(row: dict, what: str) -> str:
    """'paper 0.9500, plastic -, ...' of the `what`_<class> columns ('-': undefined)."""
    parts = []
    names = [k.removeprefix(f"{what}_") for k in row if k.startswith(f"{what}_")]
    for name in names:
        value = row[f"{what}_{name}"]
        parts.append(f"{name} " + ("-" if value is None else f"{value:.4f}"))
    return ", ".join(parts)


def _detection_lines(r: dict) -> list[str]:
    """Never detected (and never visible, in camera perception) as shares of the items that
    entered, beside the belt's density: detection falls as the belt fills."""
    entered = max(1, r["entered"])
    density = r.get("items_per_m")
    belt = f"; belt {density:.1f} items per metre" if density is not None else ""
    lines = [
        f"never detected         {r['never_detected']:>6}   "
        f"({100 * r['never_detected'] / entered:.1f} % of entered{belt})"
    ]
    if r.get("never_visible") is not None:
        lines.append(
            f"never visible          {r['never_visible']:>6}   "
            f"({100 * r['never_visible'] / entered:.1f} %: under 30 % of the top ever in view)"
        )
    return lines


def _horizon_lines(config, r: dict) -> list[str]:
    """The horizon's line of the summary: what it left (none without a horizon)."""
    if config.horizon_s is None:
        return []
    if r["sim_s"] < config.horizon_s - 1e-6:
        return [f"horizon                {config.horizon_s:>8g} s   (the belt was clear before it)"]
    return [
        f"ended at the horizon   {config.horizon_s:>8g} s   ({r['left_on_belt']} left on the "
        f"belt, {r['not_arrived']} not yet arrived)"
    ]


def summary(result) -> str:
    """The one-screen summary of an episode."""
    r, c = result.episode_row, result.config
    names = c.materials.names

    def per_material(what: str) -> str:
        return ", ".join(f"{n} {r[f'{what}_{n}']}" for n in names)

    lines = [
        f"episode: seed {c.seed}, {c.items} items over {c.duration_s:g} s, "
        f"belt x{c.speed_factor:g} ({c.belt_speed_mps:.3f} m/s), planner {c.planner}, "
        f"perception {c.perception}",
        *_horizon_lines(c, r),
        f"entered the belt (SI)  {r['entered']:>6}   ({per_material('entered')})",
        f"picked into bins (SP)  {r['picked']:>6}   ({per_material('picked')})",
        f"wrong bin              {r['wrong_bin']:>6}",
        f"missed (left the belt) {r['missed']:>6}",
        f"dropped                {r['dropped']:>6}",
        f"pick attempts          {r['attempts']:>6}   (failed {r['failed_picks']})",
        f"accuracy SP/SI         {r['accuracy']:>9.4f}",
        f"profit                 {r['profit_eur']:>9.2f} EUR",
        f"mean cycle             {r['mean_cycle_s']:>9.3f} s",
        "purity per bin         " + _by_class(r, "purity"),
        "recovery per class     " + _by_class(r, "recovery"),
        *_detection_lines(r),
        f"empty picks            {r['empty_picks']:>6}   (the cup never sealed)",
        f"left unsure            {r['left_unsure']:>6}   "
        f"(class probability below {c.applied_min_class_confidence:g})",
        f"simulated              {r['sim_s']:>9.1f} s in {r['wall_s']:.1f} s wall "
        f"({r['real_time_factor']:.1f}x real time)",
    ]
    timing = getattr(result, "timings", None)
    if timing:
        keys = ("physics", "perception", "decision", "planning", "video")
        parts = ", ".join(f"{k} {timing[k]:.1f} s" for k in keys if k in timing)
        lines.append(f"wall time by stage     {parts}")
    return "\n".join(lines)


def preflight(config, out: Path, video: str | Path | None) -> None:
    """Refuse, before the episode, every output and back-end it could not use (in one line).

    Args:
        config: The validated episode config.
        out: The output folder (episodes.csv, picks.csv).
        video: The MP4 path as given (a trailing separator means a folder), or None.
    """
    from sim.results import outputs
    from sim.results.timeline import INTERRUPTED_FILE, TIMELINE_FILE

    outputs.check_output_dir(out, "--out")
    for name in ("episodes.csv", "picks.csv", TIMELINE_FILE, INTERRUPTED_FILE):
        outputs.check_output_file(out / name, "--out")
    if (out / SWEEP_FILE).exists():
        from sim.errors import InvalidInput

        allowed = f"a run's folder, not a sweep's (it holds {SWEEP_FILE}: a run would replace "
        raise InvalidInput("--out", allowed + "the sweep's rows)", str(out))
    if video is not None:
        outputs.check_output_file(video, "--video", (".mp4",), "an MP4 file")
    check_perception(config)
    if video is not None:
        from sim.cell.rendering import check_backend
        from sim.render.encoder import check_encoder

        check_backend()
        check_encoder()


def check_perception(config) -> None:
    """Refuse, before the episode, what camera perception could not run without: the camera's
    calibration, the rendering back-end, a cache folder that cannot be used, a broken cache of
    the stripe HMMs, the item classifier's training table (nothing for truth perception)."""
    if config.perception != "camera":
        return
    from perception.camera.calibration import CameraCalibration
    from sim.cell.camera import DEFAULT_CALIBRATION
    from sim.cell.rendering import check_backend
    from sim.user_cache import cache_dir

    CameraCalibration.load(DEFAULT_CALIBRATION)
    check_backend()
    cache_dir()  # SORTSIM_CACHE_DIR (or the platform's folder) created and tried
    from sim.sensing.perception import hmm_cache_path
    from sim.sensing.stripe_hmms import read_cache

    catalogue, mix = config.item_catalogue, config.mix_kwargs
    cache = hmm_cache_path(catalogue, mix, config.hmm.coupled, config.belt.width_m)
    if cache.exists():
        read_cache(cache, n_states=catalogue.materials.n_states)
    if config.classifier != "hmm" and not config.catalogue:
        from sim.sensing.item_classifier import trained_item_classifier

        trained_item_classifier()  # a missing or broken training table, refused now


def main(args: argparse.Namespace) -> int:
    """Run one episode and write its files."""
    from sim.paths import remove_stale_temporaries
    from sim.results import outputs
    from sim.results.locks import FolderLock
    from sim.results.outputs import OutputError
    from sim.user_cache import existing_cache_dir

    config = load_config(args)
    out = Path(args.out)
    preflight(config, out, args.video)
    video_path = None if args.video is None else Path(args.video)
    with FolderLock(out, "--out"):
        extra = [] if video_path is None else [video_path.parent]
        extra += [cache] if (cache := existing_cache_dir()) is not None else []
        remove_stale_temporaries(out, *extra)
        progress = None if args.quiet else Progress()
        timeline = open_timeline(out, config)
        try:
            with outputs.PickStream(out / "picks.csv") as picks:
                result, video = run_streamed(config, video_path, progress, picks, out, timeline)
                if progress is not None:
                    progress.done()
                print(summary(result))
                try:
                    written = write_run(out, config, result, picks, timeline)
                except OutputError as exc:  # the one line names the video's failure too
                    if video is None or video.failure is None:
                        raise
                    too = f"the video {video_path} failed too ({video.failure})"
                    raise OutputError(f"{exc}; {too}") from None
        finally:
            timeline.close()  # its temporary removed unless it landed
    if video is not None and video.failure is None:
        assert video_path is not None  # a video is made only to a path
        written.append(video_path)
    print("wrote " + ", ".join(str(p) for p in written))
    if video is not None and video.failure is not None:
        names = ", ".join(p.name for p in written)
        failed = f"the video {video_path} failed ({video.failure})"
        raise OutputError(f"{failed}; {names} are written in {out}")
    return 0


def open_timeline(out: Path, config):
    """The timeline's writer, streaming its rows into a temporary beside `out`/timeline.csv."""
    from sim.results.timeline import TIMELINE_FILE, TimelineWriter, timeline_columns

    out.mkdir(parents=True, exist_ok=True)
    return TimelineWriter(out / TIMELINE_FILE, timeline_columns(config.robot_count))


def run_streamed(config, video_path: Path | None, progress, picks, out: Path, timeline=None):
    """`run_with_video` with the picks streamed to `picks` (`sim.results.outputs.PickStream`);
    a Ctrl-C (or SIGTERM, SIGHUP) lands the picks finished so far in
    `<out>/picks.interrupted.csv` (the folder's other files stay as they were), says so in one
    line and stops the command as before."""
    from sim.cli.main import Stopped
    from sim.results.outputs import INTERRUPTED_PICKS

    try:
        return run_with_video(config, video_path, progress, picks, timeline)
    except (KeyboardInterrupt, Stopped):
        if progress is not None:
            progress.done()
        where = picks.land(out / INTERRUPTED_PICKS)
        print(f"sortsim run: the {picks.rows} picks finished are in {where}", file=sys.stderr)
        if timeline is not None:
            from sim.results.timeline import INTERRUPTED_FILE

            where = timeline.land(out / INTERRUPTED_FILE)
            print(f"sortsim run: the timeline so far is in {where}", file=sys.stderr)
        raise


def run_with_video(config, video_path: Path | None, progress, picks=None, timeline=None):
    """Run the episode, its video (if any) through `KeptVideo`, so a failing video stops the
    video only.

    Args:
        config: The episode's config.
        video_path: The MP4 to write, or None.
        progress: The progress callback, or None.
        picks: Where the picks.csv rows go as they happen (`run_episode`'s `picks`), or None.
        timeline: Where the timeline's rows go (`sim.results.timeline.TimelineWriter`), or None.

    Returns:
        (the episode's result, the `KeptVideo` or None).
    """
    from sim.episode.runner import config_cell, episode_video, run_episode

    if video_path is None:
        return run_episode(config, progress=progress, picks=picks, timeline=timeline), None
    cell = config_cell(config, sized=True)
    video = KeptVideo.start(episode_video, config, cell, video_path)
    try:
        result = run_episode(
            config, cell=cell, progress=progress, recorder=video, picks=picks, timeline=timeline
        )
    finally:
        video.release_stderr()
    return result, video


def write_run(out: Path, config, result, picks=None, streamed=None) -> list[Path]:
    """Write the run's episodes.csv, picks.csv, timeline.csv and manifest.json into `out` as one
    unit (the manifest last, naming the CSVs' digests); what cannot be written is kept
    elsewhere. The picks an interrupted run left (`picks.interrupted.csv`) go once a whole run
    is written.

    Args:
        out: The run's folder.
        config: The episode's config.
        result: The episode's result.
        picks: The `PickStream` its picks went to (its temporary lands as picks.csv); None:
            the result's `pick_rows`.
        streamed: The `TimelineWriter` its timeline went to (its file lands as timeline.csv);
            None: the result's `timeline_rows`.

    Returns:
        The files written.

    Raises:
        OutputError: The files could not be written (one line saying where they are kept).
    """
    from sim.results import manifest, outputs, timeline

    columns = outputs.episode_columns(config.materials) + outputs.line_columns(config.robot_count)
    steps = timeline.timeline_columns(config.robot_count)
    files: dict[str, str | Path] = {
        "episodes.csv": outputs.to_csv_text(columns, [result.episode_row]),
        "picks.csv": (
            outputs.to_csv_text(outputs.PICK_COLUMNS, result.pick_rows)
            if picks is None
            else picks.finish()
        ),
        timeline.TIMELINE_FILE: (
            timeline.to_text(steps, result.timeline_rows) if streamed is None else streamed.finish()
        ),
    }
    record = manifest.build("run", config.to_dict(), [config.seed])
    record["catalogue_digest"] = config.item_catalogue.digest  # checked when repeated
    record["files"] = {name: _digest(data) for name, data in files.items()}
    files[manifest.MANIFEST_FILE] = manifest.text(record)
    try:
        written = outputs.write_together(out, files)
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        texts = {
            n: d.read_text(encoding="utf-8") if isinstance(d, Path) else d for n, d in files.items()
        }
        kept = outputs.keep_unwritten(out, texts, f"{reason}: {exc.filename}")
        where = (
            f"they are kept in {kept} (sim.results.outputs.restore_unwritten writes them back)"
            if kept is not None
            else "and no other place could keep them"
        )
        message = f"could not write the results into {out} ({reason}); {where}"
        raise outputs.OutputError(message) from None
    (out / outputs.INTERRUPTED_PICKS).unlink(missing_ok=True)  # an earlier run's, stopped
    (out / timeline.INTERRUPTED_FILE).unlink(missing_ok=True)
    return written


def _digest(data: str | Path) -> str:
    """The SHA-256 (hex) of a file's text, or of a written file read in blocks."""
    import hashlib

    if not isinstance(data, Path):
        return hashlib.sha256(data.encode()).hexdigest()
    digest = hashlib.sha256()
    with data.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


class KeptVideo:
    """A video recorder whose failure ends the video, not the episode (a `FrameSink`).

    The first failure of the recorder (its encoder cannot write: a full disk; its process
    failed) is kept in `failure`, the partial MP4 dropped, and no frame asked for after it.
    At the end the MP4 is checked to be whole (every box inside the file, the `moov` index
    present): an encoder that stopped writing silently when the disk filled leaves a cut file,
    which is removed and counted as a failure.

    Args:
        recorder: The `sim.render.video.VideoRecorder`.
    """

    def __init__(self, recorder):
        self.recorder = recorder
        self.failure: str | None = None
        self._stderr = None

    @classmethod
    def start(cls, make, *args) -> KeptVideo:
        """A recorder `make(*args)` whose video process writes its stderr (and its
        encoder's: ffmpeg's own lines when the disk fills) to an anonymous temporary file
        instead of the terminal: `release_stderr` shows it after the episode, or, when the
        video failed, its last line becomes part of the one line that says so.

        Args:
            make: Makes the recorder (`sim.episode.runner.episode_video`).
            *args: Its arguments.

        Returns:
            The kept video.
        """
        import os
        import tempfile

        try:
            capture = tempfile.TemporaryFile()
        except OSError:  # no temporary folder: the process's stderr is left as it is
            return cls(make(*args))
        sys.stderr.flush()
        saved = os.dup(2)
        os.dup2(capture.fileno(), 2)  # the video process starts now and inherits it
        try:
            video = cls(make(*args))
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        video._stderr = capture
        return video

    def release_stderr(self) -> None:
        """Show what the video process wrote on stderr (its last line joins the failure)."""
        capture, self._stderr = self._stderr, None
        if capture is None:
            return
        try:
            capture.seek(0)
            text = capture.read().decode("utf-8", errors="replace")
        except OSError:
            text = ""
        finally:
            capture.close()
        lines = [line.strip() for line in text.splitlines() if line.strip()]
        if self.failure is not None:
            if lines:
                self.failure += f"; the encoder said: {lines[-1][:160]}"
        elif text:
            sys.stderr.write(text)

    @property
    def next_frame_time(self) -> float:
        """Sim time of the next frame [s] (never, after a failure)."""
        return math.inf if self.failure else self.recorder.next_frame_time

    @property
    def stats(self) -> dict:
        """The recorder's statistics (`VideoRecorder.stats`)."""
        return getattr(self.recorder, "stats", {})

    def due(self, t: float) -> bool:
        """Whether a frame is due at sim time `t` (never after a failure)."""
        return self.failure is None and self.recorder.due(t)

    def capture(self, data, overlay) -> None:
        """Hand the frame to the recorder; a failure ends the video."""
        if self.failure is None:
            self._guard(self.recorder.capture, data, overlay)

    def close(self):
        """Finish the MP4 and check it is whole; returns its path (None after a failure)."""
        if self.failure is not None:
            return None
        path = self._guard(self.recorder.close)
        if self.failure is None:
            problem = mp4_problem(path)
            if problem is not None:
                Path(path).unlink(missing_ok=True)
                self.failure = problem
                return None
        return path

    def abort(self) -> None:
        """Drop the partial video (the episode failed)."""
        if self.failure is None:
            self.recorder.abort()

    def _guard(self, fn, *args):
        from sim.errors import SortsimError

        try:
            return fn(*args)
        except (SortsimError, OSError) as exc:
            self.failure = " ".join(str(exc).split()) or type(exc).__name__
            if isinstance(exc, OSError):
                self.recorder.abort()
            return None


def mp4_problem(path: Path) -> str | None:
    """Why the MP4 at `path` is not whole (None when it is): its top-level boxes must lie
    inside the file and include the `moov` index, which the encoder writes last.

    Args:
        path: The MP4.

    Returns:
        None, or what is wrong in words (with the disk's free space when it is full).
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        boxes = []
        with path.open("rb") as f:
            at = 0
            while at + 8 <= size:
                f.seek(at)
                length, kind = struct.unpack(">I4s", f.read(8))
                if length == 1:
                    length = struct.unpack(">Q", f.read(8))[0]
                elif length == 0:
                    length = size - at
                if length < 8 or at + length > size:
                    break
                boxes.append(kind)
                at += length
    except OSError as exc:
        return f"its file cannot be read: {exc.strerror}"
    if b"moov" in boxes and at == size:
        return None
    free = shutil.disk_usage(path.parent).free
    full = "; its file system is full" if free < 64 * 1024 else ""
    return f"the MP4 was cut short at {size} bytes{full}"


ONE_OF = (("--speed-factor", "--belt-speed"), ("--items", "--items-per-m"))
"""Options that say the same thing in other units: one of each pair at most."""


def load_config(args: argparse.Namespace):
    """The episode's validated config: `--config`'s TOML with the options given applied (an
    option in one unit replaces the file's setting in the other)."""
    from sim import config as episode_config
    from sim.errors import InvalidInput

    for pair in ONE_OF:
        given = [o for o in pair if getattr(args, o[2:].replace("-", "_")) is not None]
        if len(given) > 1:
            raise InvalidInput(pair[1], f"one of {' or '.join(pair)}, not both", None)
    return episode_config.load(args.config, **load_keywords(args))
