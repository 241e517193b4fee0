"""A flow carried by the belt in physics and looked at once per observation period.

The cell with the robot at home, the belt at the flow's speed and the pool feeding the flow's
items at their times (handed over at belt speed, as in the episode); `rows` advances the physics
to each observation time t_k = k T and yields there, so the camera and the truth look at the
same instant. Used by the recording of a catalogue's item classifier table
(`sim.sensing.item_recording`), the camera scoring (`sim.evaluation.perception_eval`) and the
HMMs' camera recordings (`sim.evaluation.camera_recordings`).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import mujoco
import numpy as np

from sim.cell.conveyor import Belt
from sim.cell.depth_noise import ZED_CLASS
from sim.cell.item_pool import ItemPool
from sim.cell.items import Items
from sim.flow.catalogue import Catalogue
from sim.flow.config import X_CAMERA, FlowConfig
from sim.flow.generator import Flow, generate_flow
from sim.flow.ground_truth import cell_truth_from_poses, yaw_from_xmat
from sim.model.mjcf import load_scene


@dataclass
class FlowReplay:
    """The simulation of one flow on the belt (no robot motion)."""

    config: FlowConfig
    catalogue: Catalogue
    model: mujoco.MjModel
    data: mujoco.MjData
    pool: ItemPool
    flow: Flow

    @classmethod
    def start(cls, config: FlowConfig, catalogue) -> FlowReplay:
        """The cell at its `home` keyframe with the belt at the flow's speed, nothing spawned."""
        model = load_scene(materials=catalogue.materials)
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        belt = Belt(model)
        belt.set_speed(config.belt_speed_mps)
        pool = ItemPool(model, catalogue, belt)
        flow = generate_flow(config, catalogue, pool.size)
        mujoco.mj_forward(model, data)
        return cls(config, catalogue, model, data, pool, flow)

    @property
    def items(self) -> Items:
        """The items, read through the cell's accessors (no riders here)."""
        return Items(self.model, self.data, self.pool)

    def camera_perception(self, depth_noise=ZED_CLASS, mix: dict | None = None):
        """The episode's camera perception looking at this flow (`hmm` mode: the recorders
        keep the HMMs' classes and the items' features apart), its depth noise seeded by the
        flow's seed. Close it when done."""
        from sim.sensing.perception import CameraPerception

        return CameraPerception(
            self.model, self.data, self.catalogue, self.speed, self.config.observation_period_s,
            classifier="hmm", depth_noise=depth_noise, seed=self.config.seed, mix=mix,
        )  # fmt: skip

    @property
    def speed(self) -> float:
        """Belt speed [m/s]."""
        return self.config.belt_speed_mps

    def rows(self, n_rows: int) -> Iterator[int]:
        """Steps the physics to each observation time k T (k < n_rows) and yields k there."""
        period, next_item = self.config.observation_period_s, 0
        for k in range(n_rows):
            while self.data.time < k * period - 1e-9:
                next_item = self.pool.feed(self.data, self.flow, next_item)
                mujoco.mj_step(self.model, self.data)
            mujoco.mj_kinematics(self.model, self.data)
            self.pool.park_missed(self.data)
            yield k

    def truth_now(self, k: int) -> tuple[np.ndarray, np.ndarray] | None:
        """(classes (5,), codes (5,)) of row k from the items' simulated poses; None when the
        belt is empty."""
        slots = self.pool.active_slots()
        if len(slots) == 0:
            return None
        ids, items = self.pool.item_ids[slots], self.items
        period = self.config.observation_period_s
        return cell_truth_from_poses(
            items.positions(slots),
            yaw_from_xmat(items.orientations(slots)),
            self.pool.type_index[slots],
            self.flow.class_id[ids],
            self.flow.colour[ids],
            self.catalogue,
            self.config.row_pitch_m,
            x_centre=X_CAMERA + self.speed * (self.data.time - k * period),
            item_types=[self.pool.item_type(int(slot)) for slot in slots],
        )
