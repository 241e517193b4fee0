"""Scores the camera pipeline against the ground truth on items riding the belt.

A flow (`sim.flow.generator`) is dropped on the belt through the item pool, MuJoCo carries the
items on
the moving belt (the robot holds its home pose), and every observation period the belt camera's
frame goes through `perception.camera.pipeline.CameraPipeline`. The true codes of the same row come
from
the items' simulated poses (`sim.flow.ground_truth.cell_truth_from_poses`), so perception is
scored, not
trusted. Run as a module for the figures: `python -m sim.evaluation.perception_eval --help`.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np

from perception.camera.calibration import CameraCalibration
from perception.camera.grid import BeltGrid
from perception.camera.observe import ColourRules
from perception.camera.pipeline import CameraPipeline
from perception.codes import COLOURS, EMPTY_CODE, N_CODES
from perception.errors import PerceptionError
from sim.cell.camera import PERCEPTION_SAMPLES, BeltCamera, marker_points
from sim.flow.catalogue import load_catalogue
from sim.flow.config import X_CAMERA, FlowConfig
from sim.flow.ground_truth import flow_rows
from sim.flow.world import WorldVariation
from sim.paths import CAMERA_CALIBRATION_JSON as DEFAULT_CALIBRATION
from sim.sensing.flow_replay import FlowReplay

SIZE_LABELS = ("none", "small", "medium", "large")
COLOUR_LABELS = ("none", *COLOURS)


@dataclass(frozen=True, eq=False)
class CameraScore:
    """Camera codes against true codes over an episode.

    Attributes:
        speed_factor: Belt speed factor.
        n_items: Items in the flow.
        confusion: (19, 19) counts, true code - 1 by camera code - 1.
        unobserved: Rows whose frame raised a PerceptionError.
        wall_s: Wall time of the evaluation [s].
    """

    speed_factor: float
    n_items: int
    confusion: np.ndarray
    unobserved: int
    wall_s: float

    @property
    def n_cells(self) -> int:
        return int(self.confusion.sum())

    @property
    def agreement(self) -> float:
        """Fraction of observed cells whose camera code equals the true code."""
        return float(np.trace(self.confusion) / max(self.n_cells, 1))

    @property
    def busy_agreement(self) -> float:
        """Agreement over the cells where the truth or the camera saw an item."""
        busy = self.confusion.copy()
        busy[EMPTY_CODE - 1, EMPTY_CODE - 1] = 0
        return float(np.trace(busy) / max(busy.sum(), 1))

    def _collapse(self, key: np.ndarray, n: int) -> np.ndarray:
        out = np.zeros((n, n), dtype=np.int64)
        np.add.at(out, (key[:, None], key[None, :]), self.confusion)
        return out

    def size_confusion(self) -> np.ndarray:
        """(4, 4) counts true x camera over SIZE_LABELS."""
        codes = np.arange(N_CODES)  # code - 1
        key = np.where(codes == EMPTY_CODE - 1, 0, 1 + codes // len(COLOURS))
        return self._collapse(key, len(SIZE_LABELS))

    def colour_confusion(self) -> np.ndarray:
        """(7, 7) counts true x camera over COLOUR_LABELS."""
        codes = np.arange(N_CODES)
        key = np.where(codes == EMPTY_CODE - 1, 0, 1 + codes % len(COLOURS))
        return self._collapse(key, len(COLOUR_LABELS))

    def report(self) -> str:
        """Figures and confusion matrices as text."""
        lines = [
            f"x{self.speed_factor:g}, {self.n_items} items: {self.n_cells} cells,"
            f" agreement {100 * self.agreement:.2f} %, on non-empty cells"
            f" {100 * self.busy_agreement:.2f} %, unobserved rows {self.unobserved},"
            f" {self.wall_s:.0f} s wall"
        ]
        for title, labels, matrix in (
            ("size", SIZE_LABELS, self.size_confusion()),
            ("colour", COLOUR_LABELS, self.colour_confusion()),
        ):
            lines.append(f"  {title} confusion (rows true, columns camera)")
            lines.append("  " + " " * 12 + "".join(f"{lab:>12}" for lab in labels))
            for lab, row in zip(labels, matrix, strict=True):
                lines.append("  " + f"{lab:>12}" + "".join(f"{v:12d}" for v in row))
        return "\n".join(lines)


def evaluate_camera(
    speed_factor: float,
    n_items: int,
    duration_s: float,
    seed: int = 0,
    size: tuple[int, int] = (640, 360),
    plane_z: float = 0.0,
    rules: ColourRules | None = None,
    depth: bool = True,
    world: WorldVariation | None = None,
    samples: int = PERCEPTION_SAMPLES,
) -> CameraScore:
    """Runs a flow through the cell and scores every observed row's codes.

    Args:
        speed_factor: Belt speed over x1 = 0.185 m/s.
        n_items: Items in the flow.
        duration_s: Time over which they arrive [s].
        seed: Flow seed.
        size: Camera frame (width, height) [px].
        plane_z: Height of the pipeline's rectified plane [m] (frames without depth).
        rules: Colour rules of the pipeline.
        depth: Give the pipeline the camera's depth map as well as the frame.
        world: How the items vary (default: the varied world). The truth's codes take each
            item's nominal colour, so in the varied world a printed label or a jittered shade
            that changes a cell's dominant colour counts against the camera.
        samples: Multisamples per pixel of the frames (default: the episode's camera's).
    """
    start = time.perf_counter()
    catalogue = load_catalogue()
    config = FlowConfig(
        n_items=n_items, duration_s=duration_s, speed_factor=speed_factor, seed=seed,
        world=WorldVariation() if world is None else world,
    )  # fmt: skip
    replay = FlowReplay.start(config, catalogue)
    data, speed = replay.data, replay.speed
    calibration = CameraCalibration.load(DEFAULT_CALIBRATION).scaled(size)
    grid = BeltGrid(x_line=X_CAMERA, period_s=config.observation_period_s)
    pipeline = CameraPipeline(
        calibration, grid, *marker_points(replay.model, data), plane_z=plane_z, rules=rules
    )
    confusion = np.zeros((N_CODES, N_CODES), dtype=np.int64)
    unobserved = 0
    with BeltCamera(replay.model, *size, samples=samples) as camera:
        for k in replay.rows(flow_rows(replay.flow, catalogue)):
            try:
                if depth:
                    frame, z = camera.render_rgbd(data)
                else:
                    frame, z = camera.render(data), None
                row = pipeline.observe(frame, speed, data.time, z)
            except PerceptionError:
                unobserved += 1
                continue
            truth = replay.truth_now(k)
            codes = np.full(len(row.codes), EMPTY_CODE) if truth is None else truth[1]
            np.add.at(confusion, (codes - 1, row.codes - 1), 1)
    return CameraScore(speed_factor, n_items, confusion, unobserved, time.perf_counter() - start)


def main(argv: list[str] | None = None) -> int:
    """Prints the agreement and confusion matrices of each speed factor."""
    parser = argparse.ArgumentParser(
        prog="python -m sim.evaluation.perception_eval", description=__doc__
    )
    parser.add_argument("--speed-factors", type=float, nargs="+", default=[1.0, 1.2, 1.5])
    parser.add_argument("--items", type=int, default=150)
    parser.add_argument("--duration", type=float, default=90.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=360)
    parser.add_argument("--plane-z", type=float, default=0.0)
    parser.add_argument("--no-depth", action="store_true", help="frames only, no depth map")
    parser.add_argument(
        "--samples", type=int, default=PERCEPTION_SAMPLES, help="multisamples per pixel"
    )
    parser.add_argument(
        "--uniform",
        action="store_true",
        help="the uniform world (nominal colours and sizes, as tests/test_observe.py scores)",
    )
    args = parser.parse_args(argv)
    for factor in args.speed_factors:
        score = evaluate_camera(
            factor,
            args.items,
            args.duration,
            args.seed,
            (args.width, args.height),
            args.plane_z,
            depth=not args.no_depth,
            world=WorldVariation.uniform() if args.uniform else None,
            samples=args.samples,
        )
        print(score.report(), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
