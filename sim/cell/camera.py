"""Off-screen frames of the cell's belt camera, seen through a real lens.

`BeltCamera` renders the MJCF camera `belt_camera` with reused `mujoco.Renderer`s (run under
`MUJOCO_GL=egl`; `sim.cell.rendering` refuses a back-end that cannot render) and passes the
pinhole render through `perception.camera.lens.LensDistorter`, so the frames carry the
distortion of a real wide lens. MuJoCo's pinhole has square pixels, the principal point at the
image centre and the vertical field of view `fovy`; since barrel distortion shows rays from
outside that field, the pinhole render is made on a larger canvas with the same focal length
(the camera's fovy is widened for that render only).

Two passes make a frame with depth, each drawing only what its output holds. The depth pass is
MuJoCo's segmentation render, which turns multisampling off (`glDisable(GL_MULTISAMPLE)`): its
depth is that of each pixel's centre whatever the context's sample count, so it runs on a
context of one sample and skips clearing and resolving four (the same depth:
`tests/test_camera.py`). The colour pass has the camera's multisampling (`samples`: the
model's unless given; the perception's frames take `PERCEPTION_SAMPLES`); it leaves out the
skybox when the depth pass found geometry nearer than the skybox at every pixel (the belt camera
looks down at the belt and the floor), since the skybox is drawn only where nothing opaque lies
nearer. (The depth pass sees transparent geoms too: one with nothing but sky behind it would
hide that sky from the test; in the cell the belt and the floor lie behind everything.)

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

import math

import cv2
import mujoco
import numpy as np

from perception.camera.calibration import CameraCalibration
from perception.camera.grid import BeltGrid
from perception.camera.lens import (
    ZED_HD_LEFT,
    LensDistorter,
    LensModel,
    source_canvas,
    window_source,
)
from perception.camera.pipeline import CameraPipeline
from sim.cell.rendering import check_backend
from sim.errors import InvalidInput, ModelFileError
from sim.paths import CAMERA_CALIBRATION_JSON

CAMERA_NAME = "belt_camera"
MARKER_NAMES = ("marker_0", "marker_1", "marker_2", "marker_3")
DEFAULT_CALIBRATION = CAMERA_CALIBRATION_JSON
FRAME_SIZE = (640, 360)
"""The belt camera's frame size by default [px] (an episode config's `[camera]` may change it)."""


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
    cam = camera_id(model, name)
    rot = data.cam_xmat[cam].reshape(3, 3) @ np.diag([1.0, -1.0, -1.0])
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
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int = 1280,
        height: int = 720,
        lens: LensModel | None = ZED_HD_LEFT,
        name: str = CAMERA_NAME,
        samples: int | None = None,
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
            distorter = LensDistorter(self.camera_matrix, lens, self.size, src_matrix, src_size)
        self.lens = lens
        self.source_matrix = src_matrix
        """(3, 3) intrinsics of the pinhole canvas the frames are distorted from [px]."""
        check_backend()  # once per process: a missing back-end refused in one line
        self.samples = int(samples)
        self._passes = _RenderPasses(model, self._cam, src_size, self.camera_matrix[1, 1],
                                     samples, distorter)  # fmt: skip
        self._windows: dict[tuple[int, int, int, int], CameraWindow] = {}

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """The camera's frame of the current state of `data` (height, width, 3) uint8."""
        return self._passes.render(data, depth=False)[0]

    def render_rgbd(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """The frame and its registered depth map (height, width) float32 [m along the optical
        axis], as a stereo camera like the ZED delivers them (same lens, same pixels)."""
        return self._passes.render(data, depth=True)

    def window(self, rows: slice, cols: slice) -> CameraWindow:
        """The camera reading out only frame rows `rows` and columns `cols` (`CameraWindow`),
        made once per window and closed with the camera."""
        key = (int(rows.start), int(rows.stop), int(cols.start), int(cols.stop))
        window = self._windows.get(key)
        if window is None:
            window = self._windows[key] = CameraWindow(self, slice(*key[:2]), slice(*key[2:]))
        return window

    def close(self) -> None:
        """Frees the renderers' GL contexts (its windows' too)."""
        self._passes.close()
        for window in self._windows.values():
            window.close()
        self._windows.clear()

    def __enter__(self) -> BeltCamera:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _RenderPasses:
    """The two passes of a frame with depth on one pinhole canvas (see the module docstring):
    the depth pass (MuJoCo's segmentation render, one sample) and the colour pass (`samples`),
    then the lens's distortion.

    Args:
        model: The compiled cell.
        cam: The camera's id.
        canvas: The pinhole canvas (width, height) [px], centred on the optical axis.
        focal_px: Its focal length [px].
        samples: Multisamples per pixel of the colour pass.
        distorter: The lens's distortion onto the output (None: the canvas is the output).
    """

    def __init__(self, model, cam: int, canvas, focal_px: float, samples: int, distorter):
        self.model, self._cam, self._distorter = model, cam, distorter
        self._canvas_size = (int(canvas[0]), int(canvas[1]))
        self._fovy = math.degrees(2.0 * math.atan(0.5 * canvas[1] / focal_px))
        vis = model.vis.global_
        vis.offwidth = max(vis.offwidth, self._canvas_size[0])
        vis.offheight = max(vis.offheight, self._canvas_size[1])
        self._renderer = renderer_with_samples(model, *self._canvas_size, samples)
        self._depth_renderer: mujoco.Renderer | None = None  # made for the first depth frame
        self._sky_depth_m = skybox_depth(model, focal_px, self._canvas_size)

    def render(self, data: mujoco.MjData, depth: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """(colour (h, w, 3) uint8, depth (h, w) float32 [m] or None) of the current state."""
        fovy = float(self.model.cam_fovy[self._cam])
        self.model.cam_fovy[self._cam] = self._fovy
        try:
            z = self._depth_pass(data) if depth else None
            sky_seen = z is None or bool(np.any(z >= self._sky_depth_m))
            renderer = self._renderer
            renderer.update_scene(data, camera=self._cam)
            renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = sky_seen
            rgb = renderer.render()
        finally:
            self.model.cam_fovy[self._cam] = fovy
        if self._distorter is None:
            return rgb, z
        rgb = self._distorter.apply(rgb)
        if z is not None:
            z = self._distorter.apply(z, cv2.INTER_NEAREST)
        return rgb, z

    def _depth_pass(self, data: mujoco.MjData) -> np.ndarray:
        """The pinhole canvas's depth (height, width) float32 [m along the optical axis]."""
        if self._depth_renderer is None:
            self._depth_renderer = renderer_with_samples(self.model, *self._canvas_size, 0)
            self._depth_renderer.enable_depth_rendering()
        renderer = self._depth_renderer
        renderer.update_scene(data, camera=self._cam)
        return renderer.render()

    def close(self) -> None:
        """Frees the renderers' GL contexts."""
        self._renderer.close()
        if self._depth_renderer is not None:
            self._depth_renderer.close()


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
        distorter = LensDistorter(
            camera.camera_matrix, lens, camera.size, part_matrix, canvas, (rows, cols)
        )
        self._passes = _RenderPasses(camera.model, camera._cam, canvas, part_matrix[1, 1],
                                     camera.samples, distorter)  # fmt: skip

    def render_rgbd(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """The window of the frame (rows, cols, 3) uint8 and of its depth map (rows, cols)
        float32 [m along the optical axis] (`BeltCamera.render_rgbd`)."""
        return self._passes.render(data, depth=True)

    def close(self) -> None:
        """Frees the renderers' GL contexts."""
        self._passes.close()


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
    return CameraPipeline(calibration, grid or BeltGrid(), *marker_points(model, data, markers))
