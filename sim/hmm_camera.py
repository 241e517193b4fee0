"""Recordings for the stripe HMMs seen through the simulated camera (hmm-eval in camera mode).

The seed's flow is dropped through the item pool and carried by the belt in MuJoCo physics (the
robot holds its home pose); every observation period the belt camera's frame goes through
`perception.pipeline.CameraPipeline` with its registered depth map (as a stereo camera gives),
which gives the row's codes. The row's true classes come
from the items' simulated poses (`sim.truth.cell_truth_from_poses`), so the labels follow the
items where the belt really carried them. The true item centres for the item scores are the
flow's nominal ones (an item that rolled or slid on the belt is scored where it was dropped to
be). A frame the pipeline refuses (PerceptionError) repeats the previous row's codes.
"""

from __future__ import annotations

import mujoco
import numpy as np

from perception.calibration import CameraCalibration
from perception.codes import EMPTY_CODE, VOID
from perception.errors import PerceptionError
from perception.grid import BeltGrid
from perception.pipeline import CameraPipeline
from sim.belt import Belt
from sim.camera import BeltCamera, marker_points
from sim.cmd_calibrate import DEFAULT_CALIBRATION
from sim.flow import generate_flow
from sim.flow_config import X_CAMERA, X_INFEED, FlowConfig, stripe_of
from sim.hmm_dataset import DURATION_S, Recording, conditions
from sim.item_pool import ItemPool
from sim.model import load_scene
from sim.truth import cell_truth_from_poses, flow_rows, yaw_from_xmat

FRAME_SIZE = (640, 360)


def camera_recording(seed: int, catalogue) -> Recording:
    """The recording of `seed` with camera codes and pose-based true classes."""
    speed_factor, n_items = conditions(seed)
    config = FlowConfig(
        n_items=n_items, duration_s=DURATION_S, speed_factor=speed_factor, seed=seed
    )
    model = load_scene()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    belt = Belt(model)
    speed = config.belt_speed_mps
    belt.set_speed(speed)
    pool = ItemPool(model, catalogue, belt)
    flow = generate_flow(config, catalogue, pool.size)
    mujoco.mj_forward(model, data)
    calibration = CameraCalibration.load(DEFAULT_CALIBRATION).scaled(FRAME_SIZE)
    period = config.observation_period_s
    pipeline = CameraPipeline(
        calibration, BeltGrid(x_line=X_CAMERA, period_s=period), *marker_points(model, data)
    )
    n_rows = flow_rows(flow, catalogue)
    classes = np.full((n_rows, 5), VOID, dtype=np.int64)
    codes = np.full((n_rows, 5), EMPTY_CODE, dtype=np.int64)
    refused, next_item = 0, 0
    with BeltCamera(model, *FRAME_SIZE) as camera:
        for k in range(n_rows):
            while data.time < k * period - 1e-9:
                while next_item < len(flow) and flow.t_spawn[next_item] <= data.time:
                    i = next_item
                    rgba = catalogue.colour_rgba(int(flow.colour[i]))
                    type_index = int(flow.type_index[i])
                    pool.spawn(data, i, type_index, X_INFEED, flow.y[i], flow.yaw[i], rgba)
                    next_item += 1
                mujoco.mj_step(model, data)
            mujoco.mj_kinematics(model, data)
            pool.park_missed(data)
            try:
                frame, depth = camera.render_rgbd(data)
                codes[k] = pipeline.observe(frame, speed, data.time, depth).codes
            except PerceptionError:
                refused += 1
                codes[k] = codes[k - 1] if k else EMPTY_CODE
            slots = pool.active_slots()
            if len(slots):
                ids, bodies = pool.item_ids[slots], pool.body_ids[slots]
                classes[k], _ = cell_truth_from_poses(
                    data.xpos[bodies],
                    yaw_from_xmat(data.xmat[bodies]),
                    pool.type_index[slots],
                    flow.class_id[ids],
                    flow.colour[ids],
                    catalogue,
                    config.row_pitch_m,
                    x_centre=X_CAMERA + speed * (data.time - k * period),
                )
    recording = Recording(
        seed=seed,
        speed_factor=speed_factor,
        row_pitch_m=config.row_pitch_m,
        classes=classes,
        codes=codes,
        item_b=speed * np.asarray(flow.tau),
        item_y=np.asarray(flow.y),
        item_class=np.asarray(flow.class_id),
        item_cell=np.stack([flow.row, stripe_of(flow.y)], axis=1),
        refused_rows=refused,
    )
    return recording
