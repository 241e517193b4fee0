"""`sortsim calibrate`: calibrates the belt camera from rendered checkerboard views.

Renders a checkerboard target in `--poses` seeded poses in front of the cell's camera (through
the lens model), finds the corners, runs `cv2.calibrateCamera` and writes the intrinsics and
distortion to a JSON file the camera pipeline loads. It prints the result next to the
renderer's true focal length (known here from the camera's fovy), so the calibration is checked,
not trusted. Every option, the scene and the output path are checked before anything is
rendered (a refusal is one line, exit 2); the JSON is written atomically.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sim.paths import CAMERA_CALIBRATION_JSON, SCENE_XML

DEFAULT_CALIBRATION = CAMERA_CALIBRATION_JSON
POSES = (15, 500)
"""Fewest and most checkerboard poses."""
WIDTH_PX = (320, 4096)
"""Narrowest and widest frame [px]; the height follows the camera's 16:9."""
MAX_SEED = 2**32 - 1


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim calibrate`."""
    parser.add_argument(
        "--out", default=str(DEFAULT_CALIBRATION), help="where to write the calibration"
    )
    parser.add_argument("--scene", type=Path, default=SCENE_XML, help="the cell's MJCF")
    parser.add_argument("--poses", type=int, default=20, help="checkerboard poses (15+)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the poses")
    parser.add_argument("--width", type=int, default=1280, help="frame width [px]")
    parser.add_argument("--height", type=int, default=720, help="frame height [px]")


def check(args: argparse.Namespace) -> None:
    """Refuse, before anything is rendered, options and files the calibration cannot use.

    The frame must have the cell camera's 16:9 shape: the episodes scale the calibration to
    their 640x360 frames.
    """
    from sim.errors import InvalidInput
    from sim.results import outputs

    lo, hi = POSES
    if not lo <= args.poses <= hi:
        raise InvalidInput("--poses", f"{lo}..{hi}", args.poses)
    if not 0 <= args.seed <= MAX_SEED:
        raise InvalidInput("--seed", f"0..{MAX_SEED}", args.seed)
    lo, hi = WIDTH_PX
    if not lo <= args.width <= hi:
        raise InvalidInput("--width", f"{lo}..{hi} px", args.width)
    if args.height * 16 != args.width * 9:
        allowed = f"the camera's 16:9: {args.width * 9 / 16:g} px for --width {args.width}"
        raise InvalidInput("--height", allowed, args.height)
    outputs.check_output_file(args.out, "--out", (".json",), "a JSON file")
    from sim.cell.rendering import check_backend
    from sim.model.mjcf import load_model

    load_model(args.scene, ((("camera",), "belt_camera"),))
    check_backend()


def main(args: argparse.Namespace) -> int:
    """Calibrate, write the JSON file and print the figures."""
    check(args)
    args.out = Path(args.out)
    from perception.camera.calibration import calibrate
    from sim.paths import remove_stale_temporaries
    from sim.render.calibration_rig import Checkerboard, render_views

    remove_stale_temporaries(args.out.parent)
    board = Checkerboard()
    images, true_matrix = render_views(
        args.scene, board, args.poses, args.seed, (args.width, args.height)
    )
    result = calibrate(images, board.pattern, board.square_m)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    result.save(args.out)
    f_true = true_matrix[0, 0]
    fx, fy = result.camera_matrix[0, 0], result.camera_matrix[1, 1]
    print(f"views used        {result.n_views} of {len(images)}")
    print(f"focal length      fx {fx:.2f} px, fy {fy:.2f} px (renderer: {f_true:.2f} px,")
    ex, ey = 100 * (fx / f_true - 1), 100 * (fy / f_true - 1)
    print(f"                  error {ex:+.3f} % / {ey:+.3f} %)")
    print(
        f"principal point   ({result.camera_matrix[0, 2]:.2f}, {result.camera_matrix[1, 2]:.2f}) px"
        f" (renderer: ({true_matrix[0, 2]:.2f}, {true_matrix[1, 2]:.2f}))"
    )
    k1, k2, p1, p2, k3 = result.dist_coeffs
    print(f"distortion        k1 {k1:+.5f} k2 {k2:+.5f} p1 {p1:+.6f} p2 {p2:+.6f} k3 {k3:+.5f}")
    print(f"RMS reprojection  {result.rms_px:.3f} px")
    print(f"written           {args.out}")
    return 0
