"""A checkerboard target held in front of the belt camera, as for a real cell's calibration.

The target is added to the cell at run time through `mujoco.MjSpec` (a mocap body
`calibration_target`: a white plate with black squares on it, no collisions), so the calibration
scene is always the cell of the day. `target_poses` draws seeded poses that keep the whole board
in the frame at various distances, positions and tilts; `render_views` renders them through the
camera's lens.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from perception.camera.calibration import checkerboard_points
from perception.camera.lens import ZED_HD_LEFT, LensModel
from sim.cell.camera import BeltCamera, camera_pose
from sim.errors import InvalidInput

TARGET_BODY = "calibration_target"


@dataclass(frozen=True)
class Checkerboard:
    """A checkerboard of `squares` (columns, rows) of side `square_m` [m] on a white plate."""

    squares: tuple[int, int] = (10, 7)
    square_m: float = 0.03
    plate_margin_m: float = 0.03

    def __post_init__(self) -> None:
        if min(self.squares) < 3:
            raise InvalidInput("checkerboard squares", "3 or more per side", self.squares)
        if not 0.005 <= self.square_m <= 0.2:
            raise InvalidInput("checkerboard square_m", "0.005..0.2 m", self.square_m)

    @property
    def pattern(self) -> tuple[int, int]:
        """Inner corners (columns, rows), as OpenCV counts them."""
        return self.squares[0] - 1, self.squares[1] - 1

    def corner_points(self) -> np.ndarray:
        """Inner corners (N, 3) [m] in the target body's frame (centred on the board)."""
        points = checkerboard_points(self.pattern, self.square_m).astype(np.float64)
        cols, rows = self.pattern
        points[:, 0] -= 0.5 * (cols - 1) * self.square_m
        points[:, 1] -= 0.5 * (rows - 1) * self.square_m
        return points


def add_target(spec: mujoco.MjSpec, board: Checkerboard) -> None:
    """Adds the mocap checkerboard body `calibration_target` to `spec`'s world."""
    body = spec.worldbody.add_body(name=TARGET_BODY, mocap=True, pos=[0.0, 0.0, -5.0])
    cols, rows = board.squares
    half_w = 0.5 * cols * board.square_m + board.plate_margin_m
    half_h = 0.5 * rows * board.square_m + board.plate_margin_m
    common = {"contype": 0, "conaffinity": 0, "group": 1}
    body.add_geom(
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[half_w, half_h, 0.002],
        pos=[0.0, 0.0, -0.002],
        rgba=[0.95, 0.95, 0.95, 1.0],
        **common,
    )
    half = 0.5 * board.square_m
    for i in range(cols):
        for j in range(rows):
            if (i + j) % 2:
                continue
            centre = [
                (i - 0.5 * (cols - 1)) * board.square_m,
                (j - 0.5 * (rows - 1)) * board.square_m,
            ]
            body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_BOX,
                size=[half, half, 0.0005],
                pos=[centre[0], centre[1], 0.0005],
                rgba=[0.03, 0.03, 0.03, 1.0],
                **common,
            )


def calibration_model(scene: Path, board: Checkerboard) -> mujoco.MjModel:
    """The cell of `scene` with the checkerboard target added."""
    spec = mujoco.MjSpec.from_file(str(scene))
    add_target(spec, board)
    return spec.compile()


def target_poses(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    camera: BeltCamera,
    board: Checkerboard,
    n_poses: int,
    rng: np.random.Generator,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """`n_poses` seeded target poses (position [m], quaternion wxyz) that keep every corner of
    the board at least 40 px inside the frame, at 0.30..0.55 m from the camera, tilted up to
    40 degrees."""
    mujoco.mj_forward(model, data)
    cam_rot, cam_pos = camera_pose(model, data)
    width, height = camera.size
    matrix = camera.camera_matrix
    corners = board.corner_points()
    poses: list[tuple[np.ndarray, np.ndarray]] = []
    for _ in range(200 * n_poses):
        if len(poses) == n_poses:
            break
        depth = rng.uniform(0.30, 0.55)
        u, v = rng.uniform(0.05, 0.95) * width, rng.uniform(0.05, 0.95) * height
        ray = np.array([(u - matrix[0, 2]) / matrix[0, 0], (v - matrix[1, 2]) / matrix[1, 1], 1.0])
        centre_cam = ray * depth
        # The board faces the camera (its +z towards the lens), tilted and turned at random.
        tilt = Rotation.from_rotvec(np.r_[rng.uniform(-0.7, 0.7, 2), 0.0])
        turn = Rotation.from_rotvec([0.0, 0.0, rng.uniform(-np.pi, np.pi)])
        board_in_cam = Rotation.from_euler("x", np.pi) * tilt * turn
        pts_cam = board_in_cam.apply(corners) + centre_cam
        if np.any(pts_cam[:, 2] < 0.1):
            continue
        px = pts_cam[:, :2] / pts_cam[:, 2:3] * np.diag(matrix)[:2] + matrix[:2, 2]
        if np.any(px < 40) or np.any(px[:, 0] > width - 40) or np.any(px[:, 1] > height - 40):
            continue
        world_rot = Rotation.from_matrix(cam_rot) * board_in_cam
        pos = cam_rot @ centre_cam + cam_pos
        quat_xyzw = world_rot.as_quat()
        poses.append((pos, np.r_[quat_xyzw[3], quat_xyzw[:3]]))
    if len(poses) < n_poses:
        raise InvalidInput("calibration poses", "a board that fits in the frame", len(poses))
    return poses


def render_views(
    scene: Path,
    board: Checkerboard,
    n_poses: int,
    seed: int,
    size: tuple[int, int] = (1280, 720),
    lens: LensModel | None = ZED_HD_LEFT,
) -> tuple[list[np.ndarray], np.ndarray]:
    """Frames of the board in `n_poses` poses, and the true pinhole intrinsics (for checks)."""
    if n_poses < 1:
        raise InvalidInput("calibration poses", "1 or more", n_poses)
    model = calibration_model(scene, board)
    data = mujoco.MjData(model)
    body = model.body(TARGET_BODY)
    mocap = int(model.body_mocapid[body.id])
    images = []
    with BeltCamera(model, size[0], size[1], lens=lens) as camera:
        poses = target_poses(model, data, camera, board, n_poses, np.random.default_rng(seed))
        for pos, quat in poses:
            data.mocap_pos[mocap] = pos
            data.mocap_quat[mocap] = quat
            mujoco.mj_forward(model, data)
            images.append(camera.render(data))
        true_matrix = camera.camera_matrix
    return images, true_matrix
