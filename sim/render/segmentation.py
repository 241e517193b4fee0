"""Segmentation renders of a belt camera: which item each pixel of its view shows.

MuJoCo's segmentation rendering (the scene flags `mjRND_SEGMENT` and `mjRND_IDCOLOR`, as
`mujoco.Renderer.enable_segmentation_rendering` sets them) draws every geom in one flat colour
that encodes its index in the scene plus one (0: nothing), with no lighting, blending or
multisampling; the scene's geom of that index names the model geom (`objid`, `objtype`), and
the item pool (`sim.cell.item_pool`) the slot that plays it: its colliding geom and its label
sleeve are the item's. Every geom is drawn opaque, so an item under a clear bottle counts as
covered where the bottle lies over it.

`BeltSegmentation` renders a belt camera's pinhole canvas this way (the canvas `BeltCamera`
renders before its lens distorts it: the same focal length, the optical axis at its centre),
optionally at a smaller `scale` and cropped to the middle columns (`max_slope`: the belt runs
along the middle of the view). Two uses:

- the labelled frames (`sim.evaluation.frames`): the whole canvas at scale 1, distorted by
  `distort` onto the camera's frame, each frame pixel taking the canvas pixel nearest its
  undistorted ray, so the masks lie on the RGB frames `BeltCamera` renders (distorted frames,
  as the perception reads them);
- the visibility monitor (`sim.monitors.visibility`): `pixel_counts`, the pixels of each item
  inside the camera's distorted frame (`in_frame`) of a render at half scale cropped to the
  belt, without the static geoms and without building the image of slots.

It renders through a `sim.cell.camera.SceneRenderer`, the one of the cell's belt cameras when
given one (no OpenGL or MuJoCo render context of its own): a scene built for its canvas that
leaves out the geoms out of view, drawn with the segmentation flags on the renderer's context of
one sample, its pixels read as RGBA (`SceneRenderer.segmentation`). Each pixel shows the geom
that `mujoco.Renderer`'s segmentation render of the whole scene shows there
(`tests/test_visibility.py`).
"""

from __future__ import annotations

import math

import cv2
import mujoco
import numpy as np

from perception.camera.lens import ZED_HD_LEFT, LensModel, source_canvas
from sim.cell.camera import CAMERA_NAME, SceneRenderer, camera_id, true_camera_matrix
from sim.cell.item_pool import ItemPool
from sim.config.plant import FRAME_SIZE
from sim.errors import InvalidInput

NO_ITEM = -1
"""The slot of a pixel that shows no item."""
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-10)


def slot_of_geom(model: mujoco.MjModel, pool: ItemPool) -> np.ndarray:
    """(ngeom,) int16: the pool slot each geom of `model` belongs to (every family's geom and
    the label sleeve of a slot), `NO_ITEM` for a geom of no item."""
    lookup = np.full(model.ngeom, NO_ITEM, dtype=np.int16)
    slots = np.arange(pool.size)
    lookup[pool.geom_ids] = slots[:, None]
    lookup[pool.label_ids] = slots
    return lookup


class BeltSegmentation:
    """Renders which pool slot each pixel of a belt camera's pinhole canvas shows.

    Args:
        model: The compiled cell (its camera `name` and item pool).
        pool: The cell's item pool.
        size: The camera's frame (width, height) [px]: the focal length and canvas follow.
        lens: The camera's lens (None: a bare pinhole, no distortion).
        scale: Pixels of this render per pixel of the canvas, (0, 1].
        max_slope: The largest |x / z| of a ray kept (camera axes: x across the belt, z along
            the optical axis): the columns beyond it are not rendered; None keeps them all.
        name: The MJCF camera's name.
        static: Draw the world body's geoms (belt, rails, frame, camera box); False leaves
            them out (half the cost): nothing static lies between a camera and an item on the
            belt, so no item's pixels change.
        renderer: The `SceneRenderer` of `model` to render in, shared with the cell's belt
            cameras (`sim.cell.cell.Cell.belt_camera`); None: its own, closed with it.

    Attributes:
        camera_matrix: (3, 3) intrinsics of this render [px] (pixel centres at integers).
        size: (width, height) of this render [px].
        in_frame: (height, width) bool: the pixels whose ray the camera's distorted frame shows.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        pool: ItemPool,
        size: tuple[int, int] = FRAME_SIZE,
        lens: LensModel | None = ZED_HD_LEFT,
        scale: float = 1.0,
        max_slope: float | None = None,
        name: str = CAMERA_NAME,
        static: bool = True,
        renderer: SceneRenderer | None = None,
    ):
        if not 0.0 < scale <= 1.0:
            raise InvalidInput("segmentation scale", "a share in (0, 1]", scale)
        self.model, self.pool, self.lens, self.name = model, pool, lens, name
        self.settings = (tuple(size), lens, float(scale), max_slope, bool(static))
        self._option = mujoco.MjvOption()
        self._option.flags[mujoco.mjtVisFlag.mjVIS_STATIC] = bool(static)
        self.frame_size = (int(size[0]), int(size[1]))
        self.frame_matrix = true_camera_matrix(model, *self.frame_size, name)
        if lens is None:
            self.canvas_matrix, canvas = self.frame_matrix, self.frame_size
        else:
            self.canvas_matrix, canvas = source_canvas(self.frame_matrix, lens, self.frame_size)
        self.canvas_size = (int(canvas[0]), int(canvas[1]))
        focal = float(self.frame_matrix[1, 1]) * scale
        width, height = round(canvas[0] * scale), round(canvas[1] * scale)
        if max_slope is not None:
            width = min(width, 2 * math.ceil(focal * max_slope) + 2)
        self.size = (int(width), int(height))
        self.camera_matrix = np.array(
            [[focal, 0.0, (width - 1) / 2.0], [0.0, focal, (height - 1) / 2.0], [0.0, 0.0, 1.0]]
        )
        self._cam, self._focal = camera_id(model, name), focal
        self._slots = slot_of_geom(model, pool)
        self.in_frame = self._frame_mask()
        self._inside = np.flatnonzero(self.in_frame.ravel())
        # The same pixels in the order the renderer reads them (rows bottom first).
        self._inside_read = np.flatnonzero(self.in_frame[::-1].ravel())
        vis = model.vis.global_
        vis.offwidth, vis.offheight = max(vis.offwidth, width), max(vis.offheight, height)
        self._own_renderer = renderer is None
        self.renderer = SceneRenderer(model) if renderer is None else renderer
        """The `SceneRenderer` the segmentation renders in (a cell's is its belt cameras')."""
        self._maps: tuple[np.ndarray, np.ndarray] | None = None

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """(height, width) int16: the pool slot each pixel shows, `NO_ITEM` where none.

        Args:
            data: The cell's state, its kinematics current (`Items.kinematics()`).
        """
        ids = self._render_ids(data)[::-1]
        present = np.flatnonzero(np.bincount(ids.ravel(), minlength=1))
        lookup = np.full(int(present[-1]) + 1, NO_ITEM, dtype=np.int16)
        lookup[present] = self._slots_of(present)
        return lookup[ids]

    def pixel_counts(self, data: mujoco.MjData) -> np.ndarray:
        """(pool slots,) int: the pixels of each slot's item inside the camera's frame.

        Args:
            data: The cell's state, its kinematics current (`Items.kinematics()`).
        """
        ids = self._render_ids(data).reshape(-1).take(self._inside_read)
        by_id = np.bincount(ids)
        present = np.flatnonzero(by_id)
        slots = self._slots_of(present)
        mine = slots >= 0
        counts = np.bincount(slots[mine], by_id[present[mine]], minlength=self.pool.size)
        return counts.astype(np.int64)

    def counts(self, slots: np.ndarray) -> np.ndarray:
        """(pool slots,) int: the pixels of each slot's item inside the frame in `render`'s
        image `slots`."""
        inside = slots.ravel()[self._inside].astype(np.int64)
        return np.bincount(inside + 1, minlength=self.pool.size + 1)[1:]

    def _render_ids(self, data: mujoco.MjData) -> np.ndarray:
        """(height, width) uint16, rows bottom first: the scene index + 1 of the geom each
        pixel shows (0: none; `SceneRenderer.segmentation`), the scene built now."""
        renderer = self.renderer
        renderer.update(data, self._cam, self.size, self._focal, self._option)
        return renderer.segmentation(self.size)

    def _slots_of(self, ids: np.ndarray) -> np.ndarray:
        """The pool slots (int16) of the scene's geoms of index + 1 `ids` (`NO_ITEM`: none)."""
        geoms = self.renderer.scene.geoms
        out = np.full(len(ids), NO_ITEM, dtype=np.int16)
        for k, index in enumerate(ids.tolist()):
            if index > 0:
                geom = geoms[index - 1]
                if geom.objtype == mujoco.mjtObj.mjOBJ_GEOM:
                    out[k] = self._slots[geom.objid]
        return out

    def distort(self, slots: np.ndarray) -> np.ndarray:
        """The camera's distorted frame (height, width) int16 of a whole-canvas render (scale
        1, no crop): each frame pixel takes the canvas pixel nearest its undistorted ray, so
        the masks lie on `BeltCamera`'s frames; `NO_ITEM` outside the canvas."""
        if slots.shape != (self.canvas_size[1], self.canvas_size[0]):
            raise InvalidInput("segmentation", "a whole-canvas render (scale 1)", slots.shape)
        if self.lens is None:
            return slots
        if self._maps is None:
            width, height = self.frame_size
            u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height))
            rays = self._undistort(np.stack([u.ravel(), v.ravel()], 1))
            k = self.canvas_matrix
            map_x = (rays[:, 0] * k[0, 0] + k[0, 2]).reshape(height, width)
            map_y = (rays[:, 1] * k[1, 1] + k[1, 2]).reshape(height, width)
            self._maps = (map_x.astype(np.float32), map_y.astype(np.float32))
        return cv2.remap(
            slots,
            *self._maps,
            cv2.INTER_NEAREST,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=NO_ITEM,
        )

    def _undistort(self, pixels: np.ndarray) -> np.ndarray:
        """Normalised undistorted rays (N, 2) of distorted frame pixels (N, 2)."""
        points = pixels.reshape(-1, 1, 2).astype(np.float64)
        assert self.lens is not None  # only a lens distorts
        coefficients = self.lens.dist_coeffs()
        out = cv2.undistortPoints(
            points, self.frame_matrix, coefficients, None, None, None, _UNDISTORT_CRITERIA
        )
        return out.reshape(-1, 2)

    def _frame_mask(self) -> np.ndarray:
        """(height, width) bool: the render's pixels whose rays land inside the distorted
        frame (the lens's forward model)."""
        width, height = self.size
        u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height))
        k = self.camera_matrix
        x, y = (u.ravel() - k[0, 2]) / k[0, 0], (v.ravel() - k[1, 2]) / k[1, 1]
        rays = np.stack([x, y, np.ones_like(x)], 1)
        coefficients = np.zeros(5) if self.lens is None else self.lens.dist_coeffs()
        zero = np.zeros(3)
        frame, _ = cv2.projectPoints(rays, zero, zero, self.frame_matrix, coefficients)
        frame = frame.reshape(-1, 2)
        fw, fh = self.frame_size
        inside = (frame >= -0.5).all(1) & (frame[:, 0] < fw - 0.5) & (frame[:, 1] < fh - 0.5)
        return inside.reshape(height, width)

    def close(self) -> None:
        """Frees the segmentation's own renderer (not one lent to it)."""
        if self._own_renderer:
            self.renderer.close()

    def __enter__(self) -> BeltSegmentation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


_SHARED: dict[str, BeltSegmentation] = {}


def shared_segmentation(
    model: mujoco.MjModel,
    pool: ItemPool,
    size: tuple[int, int],
    scale: float,
    max_slope: float | None,
    name: str = CAMERA_NAME,
    renderer: SceneRenderer | None = None,
) -> BeltSegmentation:
    """This process's segmentation render of camera `name` of `model` at these settings,
    without the static geoms, made once and kept for later episodes (as `Cell.belt_camera`
    keeps the camera's renderer); the renders of another model are closed. The arguments are
    `BeltSegmentation`'s; `renderer` None: the kept render's, or one of its own for a new one.
    """
    if any(seg.model is not model for seg in _SHARED.values()):
        for shared in _SHARED.values():
            shared.close()
        _SHARED.clear()
    seg = _SHARED.get(name)
    settings = (tuple(size), ZED_HD_LEFT, float(scale), max_slope, False)
    if (
        seg is None
        or seg.settings != settings
        or (renderer is not None and seg.renderer is not renderer)
    ):
        if seg is not None:
            seg.close()
        seg = _SHARED[name] = BeltSegmentation(
            model, pool, size, scale=scale, max_slope=max_slope, name=name, static=False,
            renderer=renderer,
        )  # fmt: skip
    return seg
