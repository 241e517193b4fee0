"""What a frame of the camera path costs, stage by stage: CPU and wall milliseconds per frame.

Runs one camera episode (the headline's by default: seed 0, 100 items in 90 s at x1; `--config`
takes a config file, e.g. a line with a camera per robot) with a timer around every stage of
every observation, each stage timed without the stages it calls:

- scene: the frame's scene (`SceneRenderer.update`: `mjv_updateScene`, geoms out of view left
  out);
- render: MuJoCo's draw calls (`mjr_render`: the colour pass, the transparent geoms' depth);
- read: reading the pixels back (`mjr_readPixels`, where the software rasteriser finishes);
- lens: the rest of a frame's rendering: the depth's conversion to metres, the lens's
  distortion of colour and depth;
- depth noise: the stereo camera's depth error (`StereoDepthNoise.apply`);
- undistort/rectify: item footprints from frame and depth (`FootprintMapper`: every pixel's
  undistorted ray dropped onto the belt plane), then the row's codes (`codes`);
- HMM: the online stripe filter and its re-estimation, and the fixed-lag smoothing;
- segmentation: item blobs cut apart (`item_blobs`), features, classifier;
- tracking: the tracker's update with the period's detections;
- visibility: the monitor of how much of each item the camera sees, its own render included
  (`sim.monitors.visibility`).

Prints the median over frames of each stage's CPU time (this process's, the renderer's threads
included) beside its wall time, the median over the whole frames (every `WHOLE_FRAME_EVERY`-th:
the rest read out their band's window), the stage's total over the episode, the set-up (back-end
check, renderers, lens maps; first frames compile the renderer's shaders) and the command.

Run: `.venv/bin/python benchmarks/bench_perception.py [--quick] [--seed N] [--config FILE]
[--width W --height H]` (with MUJOCO_GL=egl PYOPENGL_PLATFORM=egl).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

STAGES = (
    "scene",
    "render",
    "read",
    "lens",
    "depth noise",
    "undistort/rectify",
    "codes",
    "HMM",
    "segmentation",
    "features",
    "classifier",
    "tracking",
    "visibility",
)
SETUP = "setup"


class StageClock:
    """Exclusive CPU and wall time of named stages, per frame: a stage's time leaves out the
    stages timed inside it, but for a stage that holds all of its time (`wrap(..., whole=True)`:
    the visibility monitor, whose render is its own). A frame starts at each camera
    observation; the tracker's and the monitor's calls go to the period's last frame."""

    def __init__(self):
        self.frames: list[dict[str, np.ndarray]] = []
        self.whole: list[bool] = []
        self.setup = np.zeros(2)
        self._stack: list[np.ndarray] = []
        self._holding = 0

    def start_frame(self) -> None:
        """Open the next frame's record."""
        self.frames.append(defaultdict(lambda: np.zeros(2)))
        self.whole.append(False)

    def wrap(self, owner, name: str, stage: str, whole: bool = False) -> None:
        """Time `owner.name` (a function or method) as `stage`; `whole`: with the stages it
        calls."""
        original = getattr(owner, name)
        clock = self

        def timed(*args, **kwargs):
            if clock._holding:
                return original(*args, **kwargs)
            clock._stack.append(np.zeros(2))
            clock._holding += whole
            start = np.array([time.process_time(), time.perf_counter()])
            try:
                return original(*args, **kwargs)
            finally:
                spent = np.array([time.process_time(), time.perf_counter()]) - start
                clock._holding -= whole
                inner = clock._stack.pop()
                if clock._stack:
                    clock._stack[-1] += spent
                clock._book(stage, spent - inner)

        setattr(owner, name, timed)

    def _book(self, stage: str, spent: np.ndarray) -> None:
        if stage == SETUP or not self.frames:
            self.setup += spent
        else:
            self.frames[-1][stage] += spent


def instrument(clock: StageClock) -> None:
    """Wrap every stage of the camera path (in this process only)."""
    import perception.camera.depth_footprint as footprint
    import perception.camera.pipeline as pipeline
    import perception.hmm.online as online
    import perception.items.classifier as classifier
    import sim.cell.camera as camera
    import sim.cell.cell as cell
    import sim.cell.depth_noise as depth_noise
    import sim.cell.rendering as rendering
    import sim.episode.builder as builder
    import sim.monitors.visibility as visibility
    import sim.sensing.perception as perception
    import sim.sensing.tracking as tracking

    observe = perception.CameraPerception.observe

    def observe_frame(self, t):
        clock.start_frame()
        return observe(self, t)

    perception.CameraPerception.observe = observe_frame
    render_rgbd = camera.BeltCamera.render_rgbd

    def whole_frame(self, data):
        if clock.whole:
            clock.whole[-1] = True
        return render_rgbd(self, data)

    camera.BeltCamera.render_rgbd = whole_frame
    for owner, name, stage in (
        (rendering, "check_backend", SETUP),
        (cell.Cell, "belt_camera", SETUP),
        (builder, "shared_segmentation", SETUP),
        (perception.CameraPerception, "__init__", SETUP),
        (camera.SceneRenderer, "update", "scene"),
        (mujoco, "mjr_render", "render"),
        (mujoco, "mjr_readPixels", "read"),
        (camera.RenderPasses, "render", "lens"),
        (depth_noise.StereoDepthNoise, "apply", "depth noise"),
        (footprint.FootprintMapper, "window_footprint_and_height", "undistort/rectify"),
        (pipeline.CameraPipeline, "row_observation", "codes"),
        (online.OnlineStripeHmms, "step", "HMM"),
        (online.OnlineStripeHmms, "smoothed_window", "HMM"),
        (perception, "item_blobs", "segmentation"),
        (perception, "item_features", "features"),
        (classifier.ItemClassifier, "probabilities", "classifier"),
        (tracking.Tracker, "update", "tracking"),
    ):
        clock.wrap(owner, name, stage)
    clock.wrap(visibility.VisibilityWatch, "measure", "visibility", whole=True)


def report(clock: StageClock, command: str) -> None:
    """Print the table of stage costs per frame."""
    n, whole = len(clock.frames), np.array(clock.whole)
    print(f"{n} frames ({int(whole.sum())} whole, the others their band's window)")
    print(f"{'stage':20s} {'CPU ms':>8s} {'wall ms':>8s} {'CPU ms':>8s} {'CPU s':>7s}")
    print(f"{'':20s} {'median':>8s} {'median':>8s} {'whole':>8s} {'total':>7s}")
    totals = np.zeros(2)
    for stage in (*STAGES, "all"):
        if stage == "all":
            costs = np.array([sum(frame.values(), np.zeros(2)) for frame in clock.frames])
        else:
            costs = np.array([frame[stage] if stage in frame else np.zeros(2)
                              for frame in clock.frames])  # fmt: skip
            totals += costs.sum(axis=0)
        median = 1000.0 * np.median(costs, axis=0)
        whole_cpu = 1000.0 * np.median(costs[whole, 0]) if whole.any() else float("nan")
        total = costs[:, 0].sum()
        print(f"{stage:20s} {median[0]:8.2f} {median[1]:8.2f} {whole_cpu:8.2f} {total:7.2f}")
    print(f"set-up (back-end check, renderers, lens maps, pipeline, the monitor's renderer): "
          f"{clock.setup[0]:.2f} s CPU")  # fmt: skip
    print(f"camera path in all: {totals[0] + clock.setup[0]:.2f} s CPU, {totals[1]:.2f} s wall "
          "besides the set-up")  # fmt: skip
    print(f"command: {command}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="30 items in 30 s")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--config", type=Path, default=None, help="an episode config file")
    parser.add_argument("--width", type=int, default=None)
    parser.add_argument("--height", type=int, default=None)
    args = parser.parse_args()
    from sim import config as episode_config
    from sim.episode.runner import config_cell, run_episode

    quick = dict(items=30, duration_s=30.0) if args.quick else {}
    config = episode_config.load(args.config, seed=args.seed, perception="camera", **quick)
    if args.width or args.height:
        size = (args.width or config.camera.width, args.height or config.camera.height)
        config = config.replace(camera=episode_config.Camera(*size, config.camera.per_robot))
    cell = config_cell(config)
    clock = StageClock()
    instrument(clock)
    run_episode(config, cell=cell)
    report(clock, "python " + " ".join([sys.argv[0], *sys.argv[1:]]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
