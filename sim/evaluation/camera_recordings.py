"""Recordings for the stripe HMMs seen through the simulated camera (hmm-eval in camera mode).

The seed's flow is dropped through the item pool and carried by the belt in MuJoCo physics (the
robot holds its home pose); every observation period the belt camera's frame goes through
`perception.camera.pipeline.CameraPipeline` with its registered depth map (as a stereo camera
gives),
which gives the row's codes. The row's true classes come
from the items' simulated poses (`sim.flow.ground_truth.cell_truth_from_poses`), so the labels
follow the
items where the belt really carried them. The true item centres for the item scores are the
flow's nominal ones (an item that rolled or slid on the belt is scored where it was dropped to
be). A frame the pipeline refuses (PerceptionError) repeats the previous row's codes.
"""

from __future__ import annotations

import numpy as np

from perception.camera.grid import BeltGrid
from perception.codes import EMPTY_CODE, VOID
from perception.errors import PerceptionError
from sim.cell.camera import PERCEPTION_SAMPLES, BeltCamera, camera_pipeline
from sim.flow.config import X_CAMERA, FlowConfig, stripe_of
from sim.flow.ground_truth import flow_rows
from sim.flow.labelled_grids import DURATION_S, Recording, conditions
from sim.sensing.flow_replay import FlowReplay

FRAME_SIZE = (640, 360)


def camera_recording(seed: int, catalogue) -> Recording:
    """The recording of `seed` with camera codes and pose-based true classes."""
    speed_factor, n_items = conditions(seed)
    config = FlowConfig(
        n_items=n_items, duration_s=DURATION_S, speed_factor=speed_factor, seed=seed
    )
    replay = FlowReplay.start(config, catalogue)
    flow, speed = replay.flow, replay.speed
    period = config.observation_period_s
    pipeline = camera_pipeline(
        replay.model, replay.data, FRAME_SIZE, BeltGrid(x_line=X_CAMERA, period_s=period)
    )
    n_rows = flow_rows(flow, catalogue)
    classes = np.full((n_rows, 5), VOID, dtype=np.int64)
    codes = np.full((n_rows, 5), EMPTY_CODE, dtype=np.int64)
    refused = 0
    with BeltCamera(replay.model, *FRAME_SIZE, samples=PERCEPTION_SAMPLES) as camera:
        for k in replay.rows(n_rows):
            try:
                frame, depth = camera.render_rgbd(replay.data)
                codes[k] = pipeline.observe(frame, speed, replay.data.time, depth).codes
            except PerceptionError:
                refused += 1
                codes[k] = codes[k - 1] if k else EMPTY_CODE
            truth = replay.truth_now(k)
            if truth is not None:
                classes[k] = truth[0]
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
