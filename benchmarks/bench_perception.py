"""Milliseconds per frame of the camera pipeline: render, undistort+rectify, coding (medians).

Scene: the cell (`models/cell/scene.xml`) with 15 catalogue items placed at random (seeded) in
and around the camera band, robot at home. Each repetition renders the belt camera's frame
through the lens model (`sim.cell.camera.BeltCamera`, with the registered depth map a stereo camera
gives), undistorts and rectifies it onto the belt plane (`CameraPipeline.rectify`: one remap
plus the marker check), codes the band's five cells from that image (`CameraPipeline.code_row`)
and, the pipeline's default when depth is given, maps the items' footprints from frame + depth
and codes them (`CameraPipeline.observe(..., depth)`: undistortion of the item pixels' rays,
3-D points, top-down splat, coding). It also prints the geometry figures of the located camera:
marker reprojection error and the grid corners' error on the belt against the true camera.

Run: `.venv/bin/python benchmarks/bench_perception.py [--quick] [--width W --height H]`
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

from perception.camera.calibration import CameraCalibration
from perception.camera.grid import BeltGrid
from perception.camera.lens import ZED_HD_LEFT
from perception.camera.pipeline import CameraPipeline
from sim.cell.camera import BeltCamera, marker_points
from sim.cell.conveyor import Belt
from sim.cell.item_pool import ItemPool
from sim.cli.calibrate import DEFAULT_CALIBRATION
from sim.evaluation.camera_checks import grid_corner_errors
from sim.flow.catalogue import load_catalogue
from sim.model.mjcf import load_scene

N_ITEMS = 15
SPEED = 0.185


def _median_ms(samples: list[float]) -> float:
    return 1000.0 * float(np.median(samples))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="10 frames instead of 60")
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=720)
    args = parser.parse_args()
    reps = 10 if args.quick else 60
    size = (args.width, args.height)

    catalogue = load_catalogue()
    model = load_scene()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    pool = ItemPool(model, catalogue, Belt(model))
    rng = np.random.default_rng(0)
    for i in range(N_ITEMS):
        type_index = int(rng.integers(len(catalogue.types)))
        colour = catalogue.colour_rgba(int(rng.integers(6)))
        x, y = -1.48 + rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)
        pool.spawn(data, i, type_index, x, y, rng.uniform(-np.pi, np.pi), colour)
    mujoco.mj_forward(model, data)

    calibration = CameraCalibration.load(DEFAULT_CALIBRATION).scaled(size)
    pipeline = CameraPipeline(calibration, BeltGrid(), *marker_points(model, data))
    times: dict[str, list[float]] = {k: [] for k in ("render", "rgbd", "rect", "code", "depth")}
    with BeltCamera(model, *size) as camera:
        view = pipeline.locate(camera.render(data))
        for k in range(reps):
            t0 = time.perf_counter()
            frame = camera.render(data)
            t1 = time.perf_counter()
            top = pipeline.rectify(frame)
            t2 = time.perf_counter()
            pipeline.code_row(top, SPEED, 0.5 * k)
            t3 = time.perf_counter()
            frame, depth = camera.render_rgbd(data)
            t4 = time.perf_counter()
            row = pipeline.observe(frame, SPEED, 0.5 * k, depth)
            t5 = time.perf_counter()
            for key, dt in zip(times, (t1 - t0, t4 - t3, t2 - t1, t3 - t2, t5 - t4), strict=True):
                times[key].append(dt)
        errors = grid_corner_errors(model, data, camera.camera_matrix, ZED_HD_LEFT, view, SPEED)
    print(f"frame {size[0]}x{size[1]}, {reps} frames, {N_ITEMS} items in view, codes {row.codes}")
    print(f"render (pinhole + lens)          {_median_ms(times['render']):8.2f} ms/frame (median)")
    print(f"render frame + depth map         {_median_ms(times['rgbd']):8.2f} ms/frame (median)")
    print(f"undistort + rectify (one remap)  {_median_ms(times['rect']):8.2f} ms/frame (median)")
    print(f"coding the rectified band        {_median_ms(times['code']):8.2f} ms/frame (median)")
    print(f"footprints from depth + coding   {_median_ms(times['depth']):8.2f} ms/frame (median)")
    print(f"marker reprojection RMS          {view.marker_rms_px:8.3f} px")
    print(
        f"grid corners on the belt         {1000 * errors.max():8.2f} mm max,"
        f" {1000 * errors.mean():.2f} mm mean (x1 grid, vs the true camera)"
    )
    quick = " --quick" if args.quick else ""
    print(
        f"command: .venv/bin/python benchmarks/bench_perception.py{quick} "
        f"--width {size[0]} --height {size[1]}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
