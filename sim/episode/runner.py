"""One closed-loop episode of the sorting cell, at the physics time step.

    flow generator -> items dropped at the infeed at their times (item pool)
    -> belt carries them (geom surfacevel) -> every observation period perception reports the
    items that crossed the camera line (truth, or camera -> codes -> HMMs -> items)
    -> tracker advances them with the belt -> when the robot is free the decision manager picks
    the next item -> ruckig intercept -> executor plays it (IK set-points every step)
    -> cup seals, lifts, releases over the bin -> bins and the discharge end are counted.

Everything happens in simulated time; the runner only decides when to call each stage. While
the robot idles the physics is stepped in blocks up to the next event (a drop, an observation,
a decision, a bookkeeping check, a video frame); while it moves, one step per control period.
The episode ends when every item has been dropped and left the belt (picked, missed, dropped)
and the robot is idle.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

from sim.cell.cell import Cell
from sim.config import EpisodeConfig
from sim.config.plant import CellSettings
from sim.episode.builder import belt_delay_s
from sim.episode.loop import Episode, make_decision_manager
from sim.episode.parts import EpisodeParts
from sim.episode.scheduler import timeline_sample
from sim.errors import InvalidInput
from sim.results.code_digest import code_digest
from sim.results.economics import ECONOMICS_COLUMNS, per_hour_columns
from sim.results.timeline import RowList, downtime_row, timeline_columns

__all__ = [
    "Cell",
    "Episode",
    "EpisodeResult",
    "make_decision_manager",
    "config_cell",
    "run_episode",
    "shared_cell",
]


@dataclass
class EpisodeResult:
    """Rows for episodes.csv and picks.csv, plus where the wall time went."""

    config: EpisodeConfig
    variant: str
    episode_row: dict
    pick_rows: list[dict]
    timings: dict[str, float] = field(default_factory=dict)
    latencies: dict[str, list[float]] = field(default_factory=dict)
    timeline_rows: list[dict] = field(default_factory=list)


_CELLS: dict[tuple[int, CellSettings, str, int, bool, tuple[float, ...], bool, int], Cell] = {}


def _economics(config: EpisodeConfig) -> dict[str, float]:
    """The `[economics]` settings episodes.csv records (`ECONOMICS_COLUMNS`)."""
    return {name: getattr(config.economics, name) for name in ECONOMICS_COLUMNS}


def planner_name(planner) -> str:
    """The name a decision manager object goes by in episodes.csv."""
    return str(getattr(planner, "name", None) or type(planner).__name__)


def shared_cell(
    settings: CellSettings | None = None,
    catalogue=None,
    robots: int = 1,
    line: bool = False,
    positions_m: tuple[float, ...] = (),
    cameras_per_robot: bool = False,
    pool_size: int | None = None,
):
    """This process's cell of `settings` (an episode config's `cell_settings`; the scene's when
    None) and `catalogue` (the default one when None; its materials name the bins): compiled
    once per process, settings and catalogue, reused by every episode run here with them, so a
    sweep over the cup's diameter, the belt's length or the catalogue gets each its own model.
    A line of `robots` stands at `positions_m` along the belt [m] (() the default spacing,
    `sim.model.line_model.LineLayout`); a line of several robots with `cameras_per_robot` has
    a belt camera for each robot. Every cell is compiled by `compile_line`, so a lone robot
    has the scene's names wherever it stands and whatever its pool. The pool has `pool_size`
    bodies (`sim.model.line_model.pool_capacity` when None: the most any flow may need; a
    line's, `line`, for several robots or one away from x = 0)."""
    from sim.model.line_model import LineLayout, compile_line, pool_capacity

    if catalogue is None:
        from sim.flow.catalogue import load_catalogue

        catalogue = load_catalogue()
    cameras = bool(cameras_per_robot) and robots > 1
    layout = LineLayout(robots, tuple(positions_m), cameras_per_robot=cameras)
    line = line or robots > 1 or layout.positions_m[0] != 0.0
    settings = settings or CellSettings()
    capacity = pool_capacity(line)
    size = capacity if pool_size is None else min(int(pool_size), capacity)
    key = (os.getpid(), settings, catalogue.digest, robots, line, layout.positions_m, cameras, size)
    if key not in _CELLS:
        model = compile_line(layout, settings, catalogue.materials, pool_size=size)
        _CELLS[key] = Cell(model, settings, catalogue, layout.prefixes, pool_capacity=capacity)
    return _CELLS[key]


def config_cell(config: EpisodeConfig, sized: bool = False):
    """This process's shared cell for `config` (`shared_cell` of its model settings,
    catalogue, robots and their positions, and a camera per robot for a line's camera
    perception with `[camera] per_robot`); with `sized`, its item pool sized for the flow of
    the config's seed (`sim.cell.item_pool.pool_size_for`: fewer parked bodies for MuJoCo to
    step, the same results), else for any flow (a cell reset with other seeds)."""
    size = None
    if sized:
        from sim.cell.item_pool import pool_size_for
        from sim.episode.builder import config_flow
        from sim.flow.generator import max_items_on_belt
        from sim.model.line_model import pool_capacity

        capacity = pool_capacity(config.line_cell)
        flow = config_flow(config, config.item_catalogue, capacity)
        size = pool_size_for(max_items_on_belt(flow), capacity)
    return shared_cell(
        config.cell_settings,
        config.item_catalogue,
        config.robot_count,
        config.line_cell,
        config.robot_positions_m,
        config.camera.per_robot and config.perception == "camera",
        pool_size=size,
    )


def run_episode(
    config: EpisodeConfig,
    variant: str = "base",
    cell: Cell | None = None,
    video_path=None,
    progress=None,
    planner=None,
    recorder=None,
    timeline=None,
    picks=None,
) -> EpisodeResult:
    """Run one episode; returns its episodes.csv row and picks.csv rows.

    Args:
        config: The episode's configuration.
        variant: Name of the sweep variant (a column of episodes.csv).
        cell: The compiled cell to run on (compiled with the config's `cell_settings`); this
            process's shared one of those settings when omitted.
        video_path: Where to write the MP4, or None.
        progress: Called with (fraction, status line) while it runs.
        planner: A decision manager object (`choose`, `reset`) to use instead of the config's;
            its `name` attribute (else its class name) goes into episodes.csv.
        recorder: Instead of an MP4, anything with the video recorder's interface that the
            loop hands its frames to (`sim.render.live_view.LiveView`: MuJoCo's viewer);
            not with `video_path`.
        timeline: Where the timeline's rows go as they are made
            (`sim.results.timeline.TimelineWriter`: the result's `timeline_rows` then empty);
            kept in memory for the result when None. The last row is at the episode's end.
        picks: Where picks.csv's rows go as the picks happen, in order (`write_row`:
            `sim.results.outputs.PickStream`; the rows held are handed over even when the
            episode stops on an exception); the result's `pick_rows` is then empty. None:
            the rows are kept for the result.
    """
    if recorder is not None and video_path is not None:
        raise InvalidInput("recorder", "a video_path or a recorder, not both", recorder)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    if cell is None:
        cell = config_cell(config, sized=True)
    video = recorder if video_path is None else episode_video(config, cell, video_path)
    if timeline is None:
        timeline = RowList(timeline_columns(config.robot_count))
    with Episode(config, cell, video, progress, planner=planner, timeline=timeline) as episode:
        episode.reset()
        metrics = episode.metrics
        if picks is not None:
            metrics.stream_picks(picks)
        try:
            episode.run()
        finally:
            metrics.finish_picks()
    parts = episode.parts
    assert parts is not None  # made by reset
    end_s = float(parts.data.time)
    if timeline.last is None or timeline.last["t_s"] < end_s:
        timeline(timeline_sample(parts, end_s))  # the end, counts closed out
    wall = time.perf_counter() - wall0
    label = config.planner if planner is None else planner_name(planner)
    row = episode_row(parts, label, variant, wall)
    timings = dict(parts.timings.seconds)
    # Physics: stepping, the executor's control loop, the cup and bins (everything else).
    timings["physics"] = wall - sum(v for k, v in timings.items() if k != "physics")
    timings["total"] = wall
    timings["cpu"] = time.process_time() - cpu0  # this process's CPU time (shared machines)
    timings["decisions"] = parts.timings.decisions
    # The video process's own CPU time (frames, encoder) [s]; a live viewer keeps none.
    timings |= {f"video_{k}": float(v) for k, v in getattr(video, "stats", {}).items()}
    latencies = parts.timings.latencies
    picks = parts.metrics.pick_rows()
    return EpisodeResult(config, variant, row, picks, timings, latencies, timeline.kept)


def episode_video(config: EpisodeConfig, cell: Cell, path):
    """The MP4 recorder of an episode on `cell`, as the config's `[video]` asks
    (`sim.render.video.VideoRecorder`)."""
    from sim.render.video import VideoRecorder

    v = config.video
    return VideoRecorder(cell.model, path, v.fps, v.width, v.height)


def episode_row(parts: EpisodeParts, planner: str, variant: str, wall_s: float) -> dict:
    """The episode's episodes.csv row, assembled in this one place: the config's columns, the
    metrics' (`EpisodeMetrics.row`, a line's `EpisodeMetrics.line_row`), the times, the code's
    digest and the per-hour columns.

    Args:
        parts: The finished episode's parts.
        planner: The decision manager's name.
        variant: Name of the sweep variant.
        wall_s: Wall time the episode took [s].
    """
    config, metrics = parts.config, parts.metrics
    sim_s = float(parts.data.time)
    energies = [s.energy.reading()[1] for s in parts.stations]
    row = {
        "seed": config.seed,
        "planner": planner,
        "speed_factor": config.speed_factor,
        "belt_speed_mps": config.belt_speed_mps,
        "n_items": config.items,
        **metrics.row(),
        "sim_s": sim_s,
        "wall_s": wall_s,
        "variant": variant,
        "perception": config.perception,
        "energy_price_eur_per_kwh": config.energy_price_eur_per_kwh,
        "min_class_confidence": config.applied_min_class_confidence,
        "items_per_m": config.items / (config.duration_s * config.belt_speed_mps),
        "real_time_factor": sim_s / wall_s if wall_s > 0 else 0.0,
        **metrics.line_row(sim_s, energies, config.coordination),
        "code_digest": code_digest(),
        **downtime_row(parts.faults, config.robot_count, sim_s),
    }
    # How long the items were fed [s]: a belt stopped or slowed stretched the feed with it.
    fed = config.duration_s + belt_delay_s(parts.faults)
    feed_s = min(fed, config.horizon_s or fed)
    return row | per_hour_columns(row, feed_s, config.robot_count, _economics(config))
