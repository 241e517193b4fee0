"""Off-screen frames of the cell's belt camera, seen through a real lens.

`BeltCamera` renders the MJCF camera `belt_camera` through MuJoCo's low-level calls
(`SceneRenderer`: run under `MUJOCO_GL=egl`; `sim.cell.rendering` refuses a back-end that cannot
render) and passes the pinhole render through `perception.camera.lens.LensDistorter`, so the
frames carry the distortion of a real wide lens. MuJoCo's pinhole has square pixels, the
principal point at the image centre and the vertical field of view `fovy`; since barrel
distortion shows rays from outside that field, the pinhole render is made on a larger canvas
with the same focal length (the camera's fovy is widened for that render only). Every pass of
every camera of a cell renders in one `SceneRenderer` (`sim.cell.cell.Cell.belt_camera`): one
OpenGL context and one MuJoCo render context per sample count, made once, each pass on its own
canvas at the off-screen buffer's corner.

A frame's depth is MuJoCo's segmentation render's (as `mujoco.Renderer` gives it), which turns
multisampling off (`glDisable(GL_MULTISAMPLE)`): the depth of each pixel's centre whatever the
context's sample count (the same depth on one sample and on four: `tests/test_camera.py`). The
colour pass has the camera's multisampling (`samples`: the model's unless given; the
perception's frames take `PERCEPTION_SAMPLES`, one sample). It leaves out the skybox when the
depth shows geometry nearer than the skybox at every pixel (the belt camera looks down at the
belt and the floor), since the skybox is drawn only where nothing opaque lies nearer. (The
depth holds transparent geoms too: one with nothing but sky behind it would hide that sky from
the test; in the cell the belt and the floor lie behind everything.)

On one sample, one colour pass gives the colour and most of the depth (`mjr_readPixels` reads
both buffers): its depth buffer holds, at each pixel, the nearest of the opaque geoms'
fragments, exactly as the segmentation pass's does (the same geometry, transforms and depth
test; shading does not move a fragment), while MuJoCo draws transparent geoms without writing
depth. So a segmentation pass of the transparent geoms alone, when the scene holds any, adds
theirs: the nearer of the two buffers at each pixel is the segmentation pass's buffer, bit for
bit (checked on every frame of the camera episodes; `tests/test_camera.py`). The colour pass
leaves the skybox out, and is drawn again with it in the rare frame whose depth shows the sky.
With multisampling the depth is still its own segmentation pass, drawn first.

The lens's maps of a camera's frame and of its windows (`perception.camera.lens`, 0.13 s of CPU
for a 640 x 360 frame) are kept on disk from one process to the next (`cached_distorter`),
under the digest of everything they depend on.

`BeltCamera.window` gives a `CameraWindow`: the camera reading out only a window of its
frames (an industrial camera's region of interest), rendered from the part of the pinhole
canvas that window samples; the camera perception reads each frame's band this way.

`true_camera_matrix` is the renderer's exact intrinsics, for tests: perception never uses it,
it calibrates the camera from checkerboard images instead (`sortsim calibrate`).

A line with a camera per robot (`sim.model.line_model`) has more belt cameras: robot k's is
`camera_name(prefix)` with the markers `marker_names(prefix)` ("" for the scene's camera, the
first robot's). Every one of them is the same camera model (lens, `fovy`, resolution) and so
shares the calibration file; its pose comes from its own markers (`camera_pipeline`).
"""

from __future__ import annotations

import contextlib
import math
import os
import zipfile
from pathlib import Path

import cv2
import mujoco
import numpy as np

from perception.camera.calibration import CameraCalibration
from perception.camera.depth_footprint import BELT_EDGE_M
from perception.camera.grid import BeltGrid
from perception.camera.lens import (
    ZED_HD_LEFT,
    LensDistorter,
    LensModel,
    distortion_maps,
    distortion_maps_key,
    source_canvas,
    window_source,
)
from perception.camera.pipeline import CameraPipeline
from perception.errors import PerceptionInputError
from sim.cell.rendering import check_backend, gl_context
from sim.errors import InvalidInput, ModelFileError
from sim.paths import CAMERA_CALIBRATION_JSON, temporary_path
from sim.user_cache import cache_dir

CAMERA_NAME = "belt_camera"
MARKER_NAMES = ("marker_0", "marker_1", "marker_2", "marker_3")
DEFAULT_CALIBRATION = CAMERA_CALIBRATION_JSON


def camera_name(prefix: str = "") -> str:
    """The belt camera of the robot of name prefix `prefix` in a line with a camera per robot
    ("": the scene's camera, the first robot's)."""
    return prefix + CAMERA_NAME


def marker_names(prefix: str = "") -> tuple[str, ...]:
    """The corner markers of the belt camera `camera_name(prefix)`, in `MARKER_NAMES`' order."""
    return tuple(prefix + name for name in MARKER_NAMES)


def camera_line(model: mujoco.MjModel, name: str = CAMERA_NAME) -> float:
    """The camera line of belt camera `name` [m]: the x it hangs at in the model (it looks
    straight down), as the cell's drawings give it."""
    cam = camera_id(model, name)
    if model.cam_bodyid[cam] != 0:
        raise ModelFileError("model", f"camera {name!r}: a belt camera hangs in the world body")
    return float(model.cam_pos[cam][0])


def camera_id(model: mujoco.MjModel, name: str = CAMERA_NAME) -> int:
    """Id of camera `name`; ModelFileError when the model has none of that name."""
    cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
    if cam < 0:
        raise ModelFileError("model", f"no camera named {name!r}")
    if np.any(model.cam_sensorsize[cam] > 0):
        raise ModelFileError("model", f"camera {name!r}: only fovy cameras are supported")
    return cam


def true_camera_matrix(
    model: mujoco.MjModel, width: int, height: int, name: str = CAMERA_NAME
) -> np.ndarray:
    """The renderer's pinhole intrinsics (3, 3) [px] at `width` x `height` (OpenCV convention:
    pixel centres at integer coordinates). For tests only."""
    cam = camera_id(model, name)
    focal = 0.5 * height / math.tan(0.5 * math.radians(model.cam_fovy[cam]))
    return np.array(
        [[focal, 0.0, (width - 1) / 2.0], [0.0, focal, (height - 1) / 2.0], [0.0, 0.0, 1.0]]
    )


def camera_pose(
    model: mujoco.MjModel, data: mujoco.MjData, name: str = CAMERA_NAME
) -> tuple[np.ndarray, np.ndarray]:
    """(R_world_from_opencv (3, 3), position (3,) [m]) of the camera, OpenCV axes (x right,
    y down, z forward). For tests only."""
    return camera_pose_of(data, camera_id(model, name))


_OPENCV_AXES = np.diag([1.0, -1.0, -1.0])
"""OpenCV's camera axes in MuJoCo's (x right, y up, looking along -z)."""


def camera_pose_of(data: mujoco.MjData, cam: int) -> tuple[np.ndarray, np.ndarray]:
    """`camera_pose` of the camera of id `cam` (`camera_id`), without looking its name up."""
    rot = data.cam_xmat[cam].reshape(3, 3) @ _OPENCV_AXES
    return rot, data.cam_xpos[cam].copy()


def marker_points(
    model: mujoco.MjModel, data: mujoco.MjData, names: tuple[str, ...] = MARKER_NAMES
) -> tuple[np.ndarray, np.ndarray]:
    """World centres (N, 3) [m] of the marker geoms (or sites) and their colours (N, 3) [0..1].

    The centre is the marker's top face centre: the point the camera sees.
    """
    positions, colours = [], []
    for name in names:
        geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
        if geom >= 0:
            top = data.geom_xmat[geom].reshape(3, 3)[:, 2] * model.geom_size[geom][2]
            positions.append(data.geom_xpos[geom] + top)
            rgba = model.geom_rgba[geom]
            if model.geom_matid[geom] >= 0:
                rgba = model.mat_rgba[model.geom_matid[geom]]
            colours.append(rgba[:3].copy())
            continue
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
        if site < 0:
            raise ModelFileError("model", f"no marker geom or site named {name!r}")
        top = data.site_xmat[site].reshape(3, 3)[:, 2] * model.site_size[site][2]
        positions.append(data.site_xpos[site] + top)
        colours.append(model.site_rgba[site][:3].copy())
    return np.array(positions), np.array(colours)


PERCEPTION_SAMPLES = 0
"""Multisamples per pixel of the frames the camera perception reads: none. Against four (the
model's), on seeds 0-2 at x1, x1.2 and x1.5: the codes agree with the truth on 98.52 % of 8790
cells against 98.38 % (`sim.evaluation.perception_eval`, uniform world, 150 items in 90 s);
the items' classes (`sim.evaluation.item_features evaluate`, varied world, 100 items) are
right for 0.982 against 0.980 from the features alone and 0.976 against 0.980 fused (the
classifier was trained on four-sample frames). The colour pass costs about half: 13 against
28 ms for the 640 x 360 frame's 896 x 508 canvas on Mesa's software renderer."""
MAX_SAMPLES = 16
"""Most multisamples per pixel a frame may ask for (OpenGL implementations offer up to 8-32)."""
SKYBOX_RANGE_SHARE = 0.7
"""MuJoCo draws the skybox around the camera at this share of the far clipping plane's distance,
after the opaque geoms and depth-tested against them: it shows only at pixels where nothing
opaque lies nearer."""


def skybox_depth(model: mujoco.MjModel, focal_px: float, canvas: tuple[int, int]) -> float:
    """The least depth [m along the optical axis] at which the skybox can show on a pinhole
    canvas of `canvas` (width, height) px and focal length `focal_px` [px]: at its corners, the
    rays furthest off the axis (1 % less, for the depth buffer's rounding)."""
    half_diagonal = math.hypot(0.5 * canvas[0], 0.5 * canvas[1])
    cos_corner = focal_px / math.hypot(focal_px, half_diagonal)
    far = model.vis.map.zfar * model.stat.extent
    return 0.99 * SKYBOX_RANGE_SHARE * far * cos_corner


def renderer_with_samples(
    model: mujoco.MjModel, width: int, height: int, samples: int
) -> mujoco.Renderer:
    """A renderer of `width` x `height` px on a context of `samples` multisamples (0: none); the
    count is read from the model when the context is made, and the model keeps its own."""
    quality = model.vis.quality
    own = quality.offsamples
    quality.offsamples = int(samples)
    try:
        return mujoco.Renderer(model, height, width)
    finally:
        quality.offsamples = own


CULL_MARGIN_PX = 8.0
"""A geom is left out of a camera's scene only when its bounding sphere lies at least this far
[px] outside the canvas's edges (the projection's rounding is far smaller)."""
_SPHERE, _ELLIPSOID = int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)
_CAPSULE, _CYLINDER = int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_CYLINDER)
_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
_GL_RGBA = 0x1908
"""OpenGL's `GL_RGBA`: a render context's `readPixelFormat` for reading four bytes a pixel."""


def bounding_radii(model: mujoco.MjModel) -> np.ndarray:
    """(ngeom,) radius [m] of a sphere about each geom's centre holding every vertex MuJoCo
    draws of it, from its size now (the item pool resizes geoms at run time); inf for the
    types not bounded here (planes, meshes, height fields), which are never left out."""
    size, kind = model.geom_size, model.geom_type
    return np.select(
        [
            (kind == _SPHERE) | (kind == _ELLIPSOID),
            kind == _CAPSULE,
            kind == _CYLINDER,
            kind == _BOX,
        ],
        [
            size.max(axis=1),
            size[:, 0] + size[:, 1],
            np.hypot(size[:, 0], size[:, 1]),
            np.sqrt(np.einsum("ij,ij->i", size, size)),
        ],
        np.inf,
    )


def geoms_out_of_view(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    cam: int,
    canvas: tuple[int, int],
    focal_px: float,
    radius: np.ndarray | None = None,
) -> np.ndarray:
    """Ids of the geoms whose bounding sphere (`bounding_radii`, or `radius` when the caller
    keeps them) lies wholly outside the view of camera `cam` on a centred pinhole canvas
    (width, height) [px] of focal length `focal_px` [px], the canvas widened by
    `CULL_MARGIN_PX` on every side: no pixel of it shows them."""
    rot = data.cam_xmat[cam].reshape(3, 3)  # camera axes: x right, y up, looking along -z
    local = (data.geom_xpos - data.cam_xpos[cam]) @ rot
    ahead = -local[:, 2]
    if radius is None:
        radius = bounding_radii(model)
    outside = np.zeros(model.ngeom, dtype=bool)
    for axis, extent in ((0, canvas[0]), (1, canvas[1])):
        slope = (0.5 * extent + CULL_MARGIN_PX) / focal_px
        # Signed distance beyond the side plane |x| = slope * depth, times its normal's length.
        beyond = np.abs(local[:, axis]) - slope * ahead
        outside |= beyond > radius * math.sqrt(1.0 + slope * slope)
    return np.flatnonzero(outside)


class SceneRenderer:
    """MuJoCo's classic renderer driven through its low-level calls for a model's belt cameras:
    one scene, one MuJoCo render context per sample count (made when first needed, its
    off-screen buffer as large as the model's `visual/global/offwidth` x `offheight`), all in
    the process's OpenGL context (`sim.cell.rendering.gl_context`). Every pass of every frame
    of the cameras sharing it renders there, each on its own canvas (a viewport at the buffer's
    corner), as `mujoco.Renderer` would render them each on its own context: the same scene
    flags, options and depth conversion, and so the same pixels. The segmentation renders of
    the cameras' views (`sim.render.segmentation`: the visibility monitor's, the labelled
    frames') render there too (`segmentation`).

    A frame's scene is built once for both of its passes (`update`), and leaves out the geoms
    no pixel of the canvas shows (`geoms_out_of_view`) when nothing couples one geom's pixels
    to another's: no light casts shadows and no material reflects. Each geom's pixels then
    come from its own fragments only (depth tested against the others'; the transparent ones,
    sorted by a stable sort on their distance, keep their order), so the frame is the same.

    Args:
        model: The compiled cell.
    """

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self.scene = mujoco.MjvScene(model, maxgeom=10000)
        self._defaults = self.scene.flags.copy()
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._contexts: dict[int, mujoco.MjrContext] = {}
        hidden = np.flatnonzero(self._option.geomgroup == 0)
        coupled = bool(np.any(model.light_castshadow)) or bool(np.any(model.mat_reflectance > 0))
        self._hide_group = None if coupled or not len(hidden) else int(hidden[-1])
        self._radii: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._gl = gl_context()

    def update(
        self,
        data: mujoco.MjData,
        cam: int,
        canvas: tuple[int, int],
        focal_px: float,
        option: mujoco.MjvOption | None = None,
    ) -> None:
        """Build the scene of camera `cam` on a centred pinhole canvas (width, height) [px] of
        focal length `focal_px` [px] (its fovy is the model's only while the scene is built),
        with the visualisation options `option` (None: MuJoCo's defaults; the geoms out of
        view are left out when it hides the same groups)."""
        model = self.model
        option = self._option if option is None else option
        fovy = float(model.cam_fovy[cam])
        model.cam_fovy[cam] = math.degrees(2.0 * math.atan(0.5 * canvas[1] / focal_px))
        groups, out = model.geom_group, np.zeros(0, dtype=np.intp)
        hide = self._hide_group
        if hide is not None and option.geomgroup[hide] == 0:
            out = geoms_out_of_view(model, data, cam, canvas, focal_px, self._bounding_radii())
        own = groups[out].copy()
        try:
            groups[out] = hide
            self._camera.fixedcamid = cam
            everything = mujoco.mjtCatBit.mjCAT_ALL.value
            mujoco.mjv_updateScene(model, data, option, None, self._camera, everything,
                                   self.scene)  # fmt: skip
        finally:
            groups[out] = own
            model.cam_fovy[cam] = fovy

    def _bounding_radii(self) -> np.ndarray:
        """`bounding_radii` of the model, computed again only when its geoms' sizes or types
        changed since (the item pool resizes geoms at run time)."""
        model, kept = self.model, self._radii
        if (
            kept is None
            or not np.array_equal(model.geom_size, kept[0])
            or not np.array_equal(model.geom_type, kept[1])
        ):
            kept = self._radii = (model.geom_size.copy(), model.geom_type.copy(),
                                  bounding_radii(model))  # fmt: skip
        return kept[2]

    def segmentation(self, canvas: tuple[int, int]) -> np.ndarray:
        """The scene's segmentation image on `canvas`: (height, width) uint16, the scene index
        + 1 of the geom each pixel shows (0: none), as `mujoco.Renderer`'s segmentation render
        finds it (one sample, no skybox), rows bottom first (OpenGL's order: `[::-1]` puts the
        top row first). A view of the four bytes a pixel read (`GL_RGBA`, read without
        conversion, unlike `GL_RGB`), whose red and green bytes hold the index + 1 (the blue
        one is 0 below 65536 geoms)."""
        flags = self.scene.flags
        flags[:] = self._defaults
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = False
        rgba = np.empty((canvas[1], canvas[0], 4), dtype=np.uint8)
        self._render(canvas, 0, rgba, None)
        return rgba.view("<u2")[..., 0]

    def depth(self, canvas: tuple[int, int]) -> np.ndarray:
        """The scene's depth (height, width) float32 [m along the optical axis] on `canvas`:
        MuJoCo's segmentation render on one sample, converted as `mujoco.Renderer` does."""
        flags = self.scene.flags
        flags[:] = self._defaults
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        raw = np.empty((canvas[1], canvas[0]), dtype=np.float32)
        self._render(canvas, 0, None, raw)
        return _metric_depth(self.model, self.scene, raw)[::-1].copy()

    def colour_and_depth(self, canvas: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """The scene's colour image (height, width, 3) uint8 on one sample without the skybox,
        and its depth (height, width) float32 [m along the optical axis] as `depth` gives it,
        from one colour pass and, when the scene holds transparent geoms, a segmentation pass
        of them alone (see the module docstring)."""
        flags = self.scene.flags
        flags[:] = self._defaults
        flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = False
        rgb = np.empty((canvas[1], canvas[0], 3), dtype=np.uint8)
        raw = np.empty((canvas[1], canvas[0]), dtype=np.float32)
        self._render(canvas, 0, rgb, raw)
        self._add_transparent_depth(canvas, raw)
        return rgb[::-1].copy(), _metric_depth(self.model, self.scene, raw)[::-1].copy()

    def _add_transparent_depth(self, canvas: tuple[int, int], raw: np.ndarray) -> None:
        """Raise the depth buffer `raw` read after a colour pass (reversed z: larger is
        nearer) to that of the transparent geoms, which the colour pass draws without writing
        depth: the buffer of a segmentation pass of them alone (MuJoCo marked them during the
        colour pass; the opaque ones are left out by their segmentation id)."""
        geoms = self.scene.geoms
        opaque = [k for k in range(self.scene.ngeom) if not geoms[k].transparent]
        if len(opaque) == self.scene.ngeom:
            return
        ids = [geoms[k].segid for k in opaque]
        flags = self.scene.flags
        flags[:] = self._defaults
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        seen = np.empty_like(raw)
        try:
            for k in opaque:
                geoms[k].segid = -1
            self._render(canvas, 0, None, seen)
        finally:
            for k, segid in zip(opaque, ids, strict=True):
                geoms[k].segid = segid
        np.maximum(raw, seen, out=raw)

    def colour(self, canvas: tuple[int, int], samples: int, skybox: bool) -> np.ndarray:
        """The scene's colour image (height, width, 3) uint8 on `canvas` at `samples`
        multisamples per pixel, with the skybox or without."""
        flags = self.scene.flags
        flags[:] = self._defaults
        flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = bool(skybox)
        rgb = np.empty((canvas[1], canvas[0], 3), dtype=np.uint8)
        self._render(canvas, samples, rgb, None)
        return rgb[::-1].copy()

    def _render(self, canvas, samples: int, rgb, depth) -> None:
        """Render the scene on `canvas` at the buffer's corner and read it into `rgb`/`depth`
        (`rgb` of four channels: read as `GL_RGBA`)."""
        self._gl.make_current()
        context = self._context(samples, canvas)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, context)
        rect = mujoco.MjrRect(0, 0, int(canvas[0]), int(canvas[1]))
        mujoco.mjr_render(rect, self.scene, context)
        if rgb is None or rgb.shape[-1] == 3:
            mujoco.mjr_readPixels(rgb, depth, rect, context)
            return
        own = context.readPixelFormat
        context.readPixelFormat = _GL_RGBA
        try:
            mujoco.mjr_readPixels(rgb, depth, rect, context)
        finally:
            context.readPixelFormat = own

    def _context(self, samples: int, canvas) -> mujoco.MjrContext:
        """The render context of `samples` multisamples, (re)made when missing or when its
        buffer is smaller than `canvas` (the model's off-screen size grows to hold it)."""
        context = self._contexts.get(samples)
        if context is not None and context.offWidth >= canvas[0] and context.offHeight >= canvas[1]:
            return context
        if context is not None:
            context.free()
        vis, quality = self.model.vis.global_, self.model.vis.quality
        vis.offwidth, vis.offheight = max(vis.offwidth, canvas[0]), max(vis.offheight, canvas[1])
        own = quality.offsamples
        quality.offsamples = int(samples)
        try:
            context = mujoco.MjrContext(self.model, mujoco.mjtFontScale.mjFONTSCALE_150.value)
        finally:
            quality.offsamples = own
        context.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._contexts[samples] = context
        return context

    def close(self) -> None:
        """Frees the render contexts (the OpenGL context is the thread's), in that context."""
        if self._contexts:
            self._gl.make_current()
        for context in self._contexts.values():
            context.free()
        self._contexts.clear()

    def __del__(self) -> None:
        # Freed in their own OpenGL context, never in whichever is current; at interpreter
        # exit, when EGL may be gone, they are left to the process's end.
        try:
            self.close()
        except Exception:  # a finaliser never raises
            pass


def _metric_depth(model: mujoco.MjModel, scene: mujoco.MjvScene, raw: np.ndarray) -> np.ndarray:
    """Depth [m along the optical axis] float32 of a reversed-z depth buffer `raw` read with
    `mjDEPTH_ZEROFAR`: `mujoco.Renderer.render`'s conversion, operation for operation (float32
    coefficients, float64 arithmetic), so the same bits."""
    extent = model.stat.extent
    zfar = np.float32(model.vis.map.zfar * extent)
    znear = np.float32(model.vis.map.znear * extent)
    out_64 = raw.astype(np.float64)
    if scene.camera[0].orthographic:
        out_64 = zfar - out_64 * (zfar - znear)
    else:
        c_coef = -(zfar + znear) / (zfar - znear)
        d_coef = -(np.float32(2) * zfar * znear) / (zfar - znear)
        c_coef = np.float32(-0.5) * c_coef - np.float32(0.5)
        d_coef = np.float32(-0.5) * d_coef
        out_64 = d_coef / (out_64 + c_coef)
    return out_64.astype(np.float32)


def cached_distorter(
    camera_matrix: np.ndarray,
    lens: LensModel,
    size: tuple[int, int],
    source_matrix: np.ndarray,
    source_size: tuple[int, int],
    window: tuple[slice, slice] | None = None,
) -> LensDistorter:
    """`perception.camera.lens.LensDistorter` of these arguments, its maps (0.13 s of CPU for a
    640 x 360 frame) read from the user's cache folder (`sim.user_cache.cache_dir`) when an
    earlier process made them: kept there under the digest of everything they depend on
    (`distortion_maps_key`), so the maps read are those it would make, byte for byte; else made
    now and kept (written atomically; a write that fails keeps nothing)."""
    args = (camera_matrix, lens, size, source_matrix, source_size, window)
    path = cache_dir() / f"lens_maps-{distortion_maps_key(*args)[:20]}.npz"
    maps = _read_maps(path)
    if maps is not None:
        with contextlib.suppress(PerceptionInputError):  # a damaged file is made again
            return LensDistorter(*args, maps=maps)
    maps = distortion_maps(*args)
    _write_maps(path, maps)
    return LensDistorter(*args, maps=maps)


def _read_maps(path: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """The lens maps kept at `path`, None when there are none (or none readable)."""
    try:
        with np.load(path) as kept:
            return kept["map1"], kept["map2"]
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None


def _write_maps(path: Path, maps: tuple[np.ndarray, np.ndarray]) -> None:
    """Keep the lens `maps` at `path` (through a temporary renamed over it)."""
    temporary = temporary_path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(temporary, "wb") as out:
            np.savez(out, map1=maps[0], map2=maps[1])
        os.replace(temporary, path)
    except OSError:
        with contextlib.suppress(OSError):
            temporary.unlink(missing_ok=True)


class BeltCamera:
    """Renders distorted frames (height, width, 3) uint8 of the belt camera.

    Args:
        model: The compiled cell (its camera `name`).
        width: Frame width [px].
        height: Frame height [px].
        lens: The lens that distorts the frames; None for the bare pinhole render.
        name: The MJCF camera's name.
        samples: Multisamples per pixel of the colour frames (0: one sample at the pixel's
            centre); None: the model's (`visual/quality/offsamples`).
        renderer: The `SceneRenderer` of `model` to render in, shared with other cameras of
            the model (`sim.cell.cell.Cell.belt_camera`); None: the camera's own, closed with
            it.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int = 1280,
        height: int = 720,
        lens: LensModel | None = ZED_HD_LEFT,
        name: str = CAMERA_NAME,
        samples: int | None = None,
        renderer: SceneRenderer | None = None,
    ):
        if not (16 <= width <= 4096 and 16 <= height <= 4096):
            raise InvalidInput("camera resolution", "16..4096 px each", (width, height))
        if samples is None:
            samples = int(model.vis.quality.offsamples)
        if not (isinstance(samples, (int, np.integer)) and 0 <= samples <= MAX_SAMPLES):
            raise InvalidInput("camera samples", f"an integer 0..{MAX_SAMPLES}", samples)
        self.model = model
        self.name = name
        self.size = (int(width), int(height))
        self._cam = camera_id(model, name)
        self.camera_matrix = true_camera_matrix(model, width, height, name)
        if lens is None:
            distorter, src_matrix, src_size = None, self.camera_matrix, self.size
        else:
            src_matrix, src_size = source_canvas(self.camera_matrix, lens, self.size)
            distorter = cached_distorter(self.camera_matrix, lens, self.size, src_matrix, src_size)
        self.lens = lens
        self.source_matrix = src_matrix
        """(3, 3) intrinsics of the pinhole canvas the frames are distorted from [px]."""
        check_backend()  # once per process: a missing back-end refused in one line
        self.samples = int(samples)
        self._own_renderer = renderer is None
        self.renderer = SceneRenderer(model) if renderer is None else renderer
        """The `SceneRenderer` every pass of the camera and of its windows renders in."""
        self._passes = RenderPasses(self.renderer, self._cam, src_size, self.camera_matrix[1, 1],
                                     samples, distorter)  # fmt: skip
        self._windows: dict[tuple[int, int, int, int], CameraWindow] = {}

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """The camera's frame of the current state of `data` (height, width, 3) uint8."""
        return self._passes.render(data, depth=False)[0]

    def render_rgbd(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """The frame and its registered depth map (height, width) float32 [m along the optical
        axis], as a stereo camera like the ZED delivers them (same lens, same pixels)."""
        frame, depth = self._passes.render(data, depth=True)
        assert depth is not None  # asked for
        return frame, depth

    def window(self, rows: slice, cols: slice) -> CameraWindow:
        """The camera reading out only frame rows `rows` and columns `cols` (`CameraWindow`),
        made once per window and closed with the camera."""
        key = (int(rows.start), int(rows.stop), int(cols.start), int(cols.stop))
        window = self._windows.get(key)
        if window is None:
            window = self._windows[key] = CameraWindow(self, slice(*key[:2]), slice(*key[2:]))
        return window

    def close(self) -> None:
        """Frees the camera's own renderer (not one lent to it); forgets its windows."""
        if self._own_renderer:
            self.renderer.close()
        self._windows.clear()

    def __enter__(self) -> BeltCamera:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class RenderPasses:
    """The two passes of a frame with depth on one pinhole canvas (see the module docstring):
    the depth pass (MuJoCo's segmentation render, one sample) and the colour pass (`samples`),
    both of one scene (`SceneRenderer.update`), then the lens's distortion.

    Args:
        renderer: The `SceneRenderer` to render in.
        cam: The camera's id.
        canvas: The pinhole canvas (width, height) [px], centred on the optical axis.
        focal_px: Its focal length [px].
        samples: Multisamples per pixel of the colour pass.
        distorter: The lens's distortion onto the output (None: the canvas is the output).
    """

    def __init__(self, renderer, cam: int, canvas, focal_px: float, samples: int, distorter):
        self._renderer, self._cam, self._distorter = renderer, cam, distorter
        self._canvas_size = (int(canvas[0]), int(canvas[1]))
        vis = renderer.model.vis.global_  # the off-screen buffer holds the canvas
        vis.offwidth = max(vis.offwidth, self._canvas_size[0])
        vis.offheight = max(vis.offheight, self._canvas_size[1])
        self._focal_px, self._samples = float(focal_px), int(samples)
        self._sky_depth_m = skybox_depth(renderer.model, focal_px, self._canvas_size)

    def render(self, data: mujoco.MjData, depth: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """(colour (h, w, 3) uint8, depth (h, w) float32 [m] or None) of the current state."""
        renderer, canvas, samples = self._renderer, self._canvas_size, self._samples
        renderer.update(data, self._cam, canvas, self._focal_px)
        if not depth:
            rgb, z = renderer.colour(canvas, samples, True), None
        elif samples == 0:  # one pass gives both (the module docstring)
            rgb, z = renderer.colour_and_depth(canvas)
            if np.any(z >= self._sky_depth_m):
                rgb = renderer.colour(canvas, samples, True)
        else:
            z = renderer.depth(canvas)
            rgb = renderer.colour(canvas, samples, bool(np.any(z >= self._sky_depth_m)))
        if self._distorter is None:
            return rgb, z
        rgb = self._distorter.apply(rgb)
        if z is not None:
            z = self._distorter.apply(z, cv2.INTER_NEAREST)
        return rgb, z


class CameraWindow:
    """A belt camera reading out only a window of its frames: the rows and columns a
    perception uses (`perception.camera.depth_footprint.FootprintMapper.roi`), as an
    industrial camera's region of interest does.

    Only the part of the pinhole canvas the window's pixels sample is rendered
    (`perception.camera.lens.window_source`: centred on the optical axis, the same focal
    length, an integer number of pixels from the whole canvas's edge, so it samples the same
    rays), then distorted onto the window. Its frames equal the whole frame's window up to the
    rasteriser's rounding (`tests/test_camera.py`) and cost what its pixels cost, plus each
    render's fixed part (`docs/perception.md`, step 1).

    Args:
        camera: The whole camera.
        rows: Frame rows of the window.
        cols: Frame columns of the window.
    """

    def __init__(self, camera: BeltCamera, rows: slice, cols: slice):
        width, height = camera.size
        if not (0 <= rows.start < rows.stop <= height and 0 <= cols.start < cols.stop <= width):
            raise InvalidInput("camera window", f"rows 0..{height}, columns 0..{width}",
                               (rows, cols))  # fmt: skip
        self.rows, self.cols = rows, cols
        self.shape = (rows.stop - rows.start, cols.stop - cols.start)
        # A bare pinhole is a lens without distortion: the window is then a crop.
        lens = camera.lens or LensModel(0.0, 0.0, 0.0, 0.0, 0.0)
        part_matrix, canvas, _ = window_source(
            camera.camera_matrix, lens, camera.source_matrix, (rows, cols)
        )
        distorter = cached_distorter(
            camera.camera_matrix, lens, camera.size, part_matrix, canvas, (rows, cols)
        )
        self._passes = RenderPasses(camera.renderer, camera._cam, canvas, part_matrix[1, 1],
                                     camera.samples, distorter)  # fmt: skip

    def render_rgbd(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """The window of the frame (rows, cols, 3) uint8 and of its depth map (rows, cols)
        float32 [m along the optical axis] (`BeltCamera.render_rgbd`)."""
        frame, depth = self._passes.render(data, depth=True)
        assert depth is not None  # asked for
        return frame, depth

    def close(self) -> None:
        """Nothing to free: the window renders in its camera's renderer."""


def belt_grid(model: mujoco.MjModel, x_line: float, period_s: float) -> BeltGrid:
    """The observation grid of a belt camera on the camera line `x_line` [m] at observation
    period `period_s` [s]: its five stripes share the model's belt (geom `belt`, whatever its
    width: `[belt] width_m`), from its -y edge to its +y edge."""
    from sim.cell.conveyor import Belt

    geometry = Belt(model).geometry
    y_min, y_max = geometry.y_centre - geometry.y_half, geometry.y_centre + geometry.y_half
    return BeltGrid(x_line=x_line, y_min=y_min, y_max=y_max, period_s=period_s)


THESIS_RAIL_VIEW_M = (0.41, 0.72)
"""The scene's rails as its belt camera sees them: their inner faces 0.41 m across from the
camera, their tops 0.72 m below it [m]."""


def belt_edge_margin(model: mujoco.MjModel, name: str = CAMERA_NAME) -> float:
    """The belt's outer strips whose pixels the camera pipeline does not take for items [m]
    (`perception.camera.depth_footprint.BELT_EDGE_M` on the scene's 0.8 m belt).

    The stereo depth's error (its sigma grows as the range squared, `sim.cell.depth_noise`)
    moves a rail's top along the camera's ray, so across the belt by the error times y / range:
    in all, in proportion to range x y. On a wider belt the rails lie farther out and farther
    away, and the margin grows so that the rails' inner faces stay as many such errors from
    where items may be seen as on the scene's belt; never below the scene's."""
    from sim.cell.conveyor import RAIL_GEOMS, Belt, rail_top_z
    from sim.flow.config import BELT_HALF_WIDTH

    belt = Belt(model).geometry
    if belt.y_half == BELT_HALF_WIDTH:
        return BELT_EDGE_M
    rail_y = min(abs(model.geom(r).pos[1]) - model.geom(r).size[1] for r in RAIL_GEOMS)
    drop = float(model.cam_pos[camera_id(model, name)][2]) - rail_top_z(model)
    y_ref, drop_ref = THESIS_RAIL_VIEW_M
    ratio = (math.hypot(rail_y, drop) * rail_y) / (math.hypot(y_ref, drop_ref) * y_ref)
    gap = rail_y - belt.y_half  # between the belt's edge and the rails' inner faces
    reference = (y_ref - BELT_HALF_WIDTH) + BELT_EDGE_M  # the rails' distance from items
    return max(BELT_EDGE_M, reference * ratio - gap)


def camera_pipeline(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    size: tuple[int, int] = (1280, 720),
    grid: BeltGrid | None = None,
    calibration_path=DEFAULT_CALIBRATION,
    markers: tuple[str, ...] = MARKER_NAMES,
) -> CameraPipeline:
    """The perception pipeline of a belt camera: the calibration file (scaled to `size`),
    the belt grid (default: camera line x = -1.48 m, T = 0.5 s) and the MJCF positions and
    colours of its markers `markers` (default: the scene's camera's), the cell's drawings. The
    belt is located from the markers on the first frame.

    Args:
        model: The compiled cell.
        data: Its data (the markers' world positions).
        size: Frame size (width, height) [px]; the calibration is scaled to it.
        grid: The belt grid on the camera's line.
        calibration_path: The lens's calibration file (`sortsim calibrate`).
        markers: The names of the camera's four corner markers (`marker_names`).

    Returns:
        The pipeline, its pose not yet solved.
    """
    calibration = CameraCalibration.load(calibration_path).scaled(size)
    margin = belt_edge_margin(model)  # every belt camera of a cell hangs as high
    return CameraPipeline(
        calibration, grid or BeltGrid(), *marker_points(model, data, markers), edge_margin_m=margin
    )
