"""Drawing the video's frames from states: what a frame is drawn from, and the painter.

A frame is drawn from a `FrameState`: the joint positions, the mocap poses and the rows of the
model fields the simulation changed since the previous frame (`MODEL_FIELDS`: an item taking its
size, colour and visibility at spawn; `ModelWatch` finds them). `FramePainter` holds its own
copy of the model and data, takes on each state and draws it from the video's view
(`sim.render.view`) with its annotations (`sim.render.labels`). The video process draws with it;
tests and benchmarks use it in-process.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from sim.cell.rendering import check_backend
from sim.render.labels import Overlay, annotate
from sim.render.view import finite_floors, ghost, ghosted_geoms, project, view_camera

SAMPLES = 0
"""Multisampling of the video's renders: none. Mesa's software renderer draws 2 and 4 samples
at the same cost, 2.6 times that of none (62 against 24 ms a 640x360 frame); without it thin
edges (the cage's bars, the belt's rims) show stair-steps, which the H.264 encoding softens."""
BOX_QUADS = 1
"""Quads per side of a box's face in the video's renders (MuJoCo's default: 4, for smoother
lighting of large boxes): 18 against 27 ms a frame with the floor below, 9 pixels of a frame
changed by more than 8 levels of 255."""
MODEL_FIELDS = (
    "geom_size",
    "geom_rgba",
    "geom_quat",
    "geom_pos",
    "geom_group",
    "geom_type",
    "geom_matid",
    "geom_dataid",
    "body_pos",
    "body_quat",
    "mat_rgba",
)
"""Model fields a frame is drawn from that the simulation may change while it runs (the item
pool sets an item's geom size, orientation, colour and group at spawn and hides it at park);
the video process receives the rows that changed since the previous frame."""


@dataclass
class FrameState:
    """What a frame is drawn from, besides the model the painter was made with.

    Attributes:
        qpos: The joint positions (nq,).
        mocap_pos: Mocap bodies' positions (nmocap, 3) [m].
        mocap_quat: Mocap bodies' orientations (nmocap, 4).
        model_rows: Per changed field of `MODEL_FIELDS`: (row indices, their new values).
    """

    qpos: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat: np.ndarray
    model_rows: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)


class ModelWatch:
    """Finds the rows of `MODEL_FIELDS` a model changed since the previous look (the first
    look compares with `model` as the painter's copy starts)."""

    def __init__(self, model: mujoco.MjModel):
        self._last = {n: getattr(model, n).copy() for n in MODEL_FIELDS if hasattr(model, n)}

    def changes(self, model: mujoco.MjModel) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """{field: (rows, values)} of the rows that differ from the previous look (which this
        look becomes)."""
        out = {}
        for name, last in self._last.items():
            now = getattr(model, name)
            differs = now != last
            if differs.ndim > 1:
                differs = differs.any(axis=tuple(range(1, differs.ndim)))
            if differs.any():
                rows = np.flatnonzero(differs)
                values = now[rows].copy()
                last[rows] = values
                out[name] = (rows, values)
        return out


def frame_state(
    model: mujoco.MjModel, data: mujoco.MjData, watch: ModelWatch | None = None
) -> FrameState:
    """The state a frame of `data` is drawn from: copies of the joint positions and mocap
    poses, and, with a `watch`, the model rows changed since its last look."""
    return FrameState(
        data.qpos.copy(),
        data.mocap_pos.copy(),
        data.mocap_quat.copy(),
        {} if watch is None else watch.changes(model),
    )


class FramePainter:
    """Draws the video's frames of given states on its own copy of the data.

    Args:
        model: The model to draw (its visual quality and off-screen buffer are set for the
            video: give the painter a model of its own).
        width: Frame width [px].
        height: Frame height [px].
        samples: Multisampling (`SAMPLES` by default).
        simplify: Draw boxes with `BOX_QUADS` and infinite floors as squares
            (`finite_floors`): a cheaper frame, all but the same.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int,
        height: int,
        samples: int = SAMPLES,
        simplify: bool = True,
    ):
        self.model = model
        self.size = (int(width), int(height))
        model.vis.quality.offsamples = int(samples)
        self._floors: dict[int, np.ndarray] = {}
        """The floors drawn as squares (`finite_floors`): their sizes are the painter's."""
        if simplify:
            model.vis.quality.numquads = BOX_QUADS
            self._floors = {g: model.geom_size[g].copy() for g in finite_floors(model)}
        vis = model.vis.global_
        vis.offwidth, vis.offheight = self.size
        self.data = mujoco.MjData(model)
        self.cam = view_camera(model)
        self._ghosts = ghosted_geoms(model)
        check_backend()
        self.renderer = mujoco.Renderer(model, height=self.size[1], width=self.size[0])

    def apply(self, state: FrameState) -> None:
        """Take on a state: the model rows that changed, the pose of every body."""
        for name, (rows, values) in state.model_rows.items():
            getattr(self.model, name)[rows] = values
        for geom, size in self._floors.items():
            self.model.geom_size[geom] = size
        self.data.qpos[:] = state.qpos
        self.data.mocap_pos[:] = state.mocap_pos
        self.data.mocap_quat[:] = state.mocap_quat
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def paint(self, overlay: Overlay | None = None) -> np.ndarray:
        """The frame of the current state, `overlay` (if any) drawn over it.

        Returns:
            The RGB frame (height, width, 3) uint8.
        """
        self.renderer.update_scene(self.data, camera=self.cam)
        ghost(self.renderer.scene, self._ghosts)
        frame = self.renderer.render().copy()
        if overlay is not None:
            scene = self.renderer.scene
            pts = np.array([it[1:4] for it in overlay.items], dtype=float).reshape(-1, 3)
            rims = np.array([(b.x, b.y, b.z) for b in overlay.bins], dtype=float).reshape(-1, 3)
            bin_uv = project(scene, rims, self.size)
            annotate(frame, project(scene, pts, self.size), overlay, bin_uv)
        return frame

    def close(self) -> None:
        """Free the renderer's GL context."""
        self.renderer.close()
