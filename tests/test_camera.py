"""The belt camera: off-screen frames, the renderer's true intrinsics and pose conventions."""

from __future__ import annotations

import math

import cv2
import mujoco
import numpy as np
import pytest

from perception.camera.rectify import colour_mask
from sim.cell.camera import (
    BeltCamera,
    _metric_depth,
    camera_id,
    camera_pose,
    geoms_out_of_view,
    marker_points,
    renderer_with_samples,
    true_camera_matrix,
)
from sim.errors import InvalidInput, ModelFileError
from sim.flow.catalogue import load_catalogue
from sim.paths import REPO_ROOT, SCENE_XML

FIXTURE = REPO_ROOT / "tests" / "models" / "belt_camera.xml"


SKYBOX = mujoco.mjtRndFlag.mjRND_SKYBOX


@pytest.fixture(scope="module")
def cell_with_items():
    """The cell with a red can, a white tray and a clear bottle (translucent) under the camera."""
    catalogue = load_catalogue()
    spec = mujoco.MjSpec.from_file(str(SCENE_XML))
    upright, lying = [1, 0, 0, 0], [0.7071068, 0, 0.7071068, 0]
    items = (
        ((-1.47, -0.06, 0.0575), upright, mujoco.mjtGeom.mjGEOM_CYLINDER, [0.033, 0.0575], "red"),
        ((-1.47, 0.05, 0.015), upright, mujoco.mjtGeom.mjGEOM_BOX, [0.1, 0.075, 0.015], "white"),
        ((-1.60, 0.2, 0.035), lying, mujoco.mjtGeom.mjGEOM_CAPSULE, [0.035, 0.08], "transparent"),
    )
    for pos, quat, kind, size, colour in items:
        body = spec.worldbody.add_body(pos=list(pos), quat=quat)
        rgba = list(catalogue.colour_rgba(colour))
        body.add_geom(type=kind, size=size, contype=0, conaffinity=0, rgba=rgba)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


@pytest.fixture(scope="module")
def fixture_model():
    model = mujoco.MjModel.from_xml_path(str(FIXTURE))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def test_frames_are_rgb_uint8_and_repeatable(fixture_model):
    model, data = fixture_model
    with BeltCamera(model, 640, 360) as camera:
        first = camera.render(data)
        second = camera.render(data)
    assert first.shape == (360, 640, 3) and first.dtype == np.uint8
    assert np.array_equal(first, second)
    assert first.max() > 200  # the white item is bright
    # The render's temporary field of view is put back.
    assert model.cam_fovy[0] == pytest.approx(60.0)


def test_true_intrinsics_follow_fovy(fixture_model):
    model, _ = fixture_model
    matrix = true_camera_matrix(model, 640, 360)
    assert matrix[0, 0] == pytest.approx(180.0 / math.tan(math.radians(30.0)))
    assert matrix[0, 0] == matrix[1, 1]
    assert matrix[0, 2] == 319.5 and matrix[1, 2] == 179.5


def test_pinhole_render_matches_the_true_camera_model(fixture_model):
    """Markers land where the true intrinsics and pose project them, within 0.5 px."""
    model, data = fixture_model
    with BeltCamera(model, 1280, 720, lens=None) as camera:
        frame = camera.render(data)
        matrix = camera.camera_matrix
    world, colours = marker_points(model, data)
    rot, pos = camera_pose(model, data)
    cam = (world - pos) @ rot  # world -> OpenCV camera frame
    expected = cam[:, :2] / cam[:, 2:3] * matrix[0, 0] + matrix[:2, 2]
    for target, rgb in zip(expected, colours, strict=True):
        mask = colour_mask(frame, rgb).astype(np.uint8)
        _, _, stats, centres = cv2.connectedComponentsWithStats(mask)
        best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        assert np.linalg.norm(centres[best] - target) < 0.5


def test_the_cell_has_the_camera_and_four_markers_on_the_belt_plane():
    model = mujoco.MjModel.from_xml_path(str(SCENE_XML))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    _, pos = camera_pose(model, data)
    assert pos == pytest.approx([-1.48, 0.0, 0.75])
    world, colours = marker_points(model, data)
    assert world.shape == (4, 3) and colours.shape == (4, 3)
    assert np.all(np.abs(world[:, 1]) > 0.4)  # beside the belt
    # Four distinct hues, so each marker is identified by its colour.
    assert len({tuple(np.round(c, 2)) for c in colours}) == 4


def test_refusals(fixture_model):
    model, _ = fixture_model
    with pytest.raises(InvalidInput, match="camera resolution"):
        BeltCamera(model, 8, 8)
    with pytest.raises(ModelFileError, match="no camera named"):
        BeltCamera(model, 64, 64, name="nope")
    for samples in (-1, 17, 2.0):
        with pytest.raises(InvalidInput, match="camera samples"):
            BeltCamera(model, 64, 64, samples=samples)


def test_depth_map_is_registered_to_the_frame(fixture_model):
    """Depth along the optical axis: the belt 0.75 m below the camera, the 1 cm boxes closer;
    bright pixels and near pixels are the same pixels (one lens, one pixel grid)."""
    model, data = fixture_model
    with BeltCamera(model, 640, 360) as camera:
        frame, depth = camera.render_rgbd(data)
        alone = camera.render(data)
    assert depth.shape == (360, 640) and depth.dtype == np.float32
    assert np.array_equal(frame, alone)
    belt = depth[40, 320]  # upstream of the boxes, on the black belt
    assert belt == pytest.approx(0.75, abs=1e-3)
    raised = np.abs(depth - 0.74) < 1e-3  # the boxes' tops, 1 cm above the belt
    bright = frame.max(axis=2) > 100
    overlap = (raised & bright).sum() / raised.sum()
    assert raised.sum() > 1000 and overlap > 0.97


def test_the_depth_pass_is_the_same_on_one_sample(cell_with_items):
    """MuJoCo's depth (segmentation) pass turns multisampling off, so the camera renders it on a
    context of one sample: the same depth as on the model's multisampled context, while the
    colour differs (the sample count did change)."""
    model, data = cell_with_items
    samples = model.vis.quality.offsamples
    assert samples > 1
    multisampled = mujoco.Renderer(model, 360, 640)
    single = renderer_with_samples(model, 640, 360, 0)
    assert model.vis.quality.offsamples == samples  # the model keeps its own
    try:
        colours, depths = [], []
        for renderer in (multisampled, single):
            renderer.update_scene(data, camera=camera_id(model))
            colours.append(renderer.render())
            renderer.enable_depth_rendering()
            depths.append(renderer.render())
    finally:
        multisampled.close()
        single.close()
    assert not np.array_equal(*colours)
    assert np.array_equal(*depths)
    assert np.ptp(depths[0]) > 0.1  # the items stand out of the belt


def test_one_colour_pass_and_the_clear_items_give_the_segmentation_passs_depth(cell_with_items):
    """On one sample the camera reads the colour and the depth of one colour pass and adds the
    transparent geoms' depth from a segmentation pass of them alone: the same frame and the
    same depth, bit for bit, as `mujoco.Renderer`'s colour render and its depth (segmentation)
    render of the whole scene, though the colour pass's own depth misses the clear bottle and
    the camera's scene leaves out the geoms out of its view (the robot, the bins)."""
    model, data = cell_with_items
    with BeltCamera(model, 640, 360, lens=None, samples=0) as camera:
        frame, depth = camera.render_rgbd(data)
        renderer = camera.renderer
        scene = renderer.scene
        transparent = [scene.geoms[k].transparent for k in range(scene.ngeom)]
        scene.flags[:] = renderer._defaults
        scene.flags[SKYBOX] = False
        own = np.empty((360, 640), np.float32)
        renderer._render((640, 360), 0, None, own)
        own = _metric_depth(model, scene, own)[::-1]
    assert 0 < sum(transparent) < len(transparent)
    reference = renderer_with_samples(model, 640, 360, 0)
    try:
        reference.update_scene(data, camera=camera_id(model))
        reference.scene.flags[SKYBOX] = False
        colours = reference.render()
        reference.enable_depth_rendering()
        depths = reference.render()
    finally:
        reference.close()
    assert len(transparent) < reference.scene.ngeom
    assert np.array_equal(frame, colours)
    assert np.array_equal(depth, depths)
    farther = own > depths + 0.01  # the colour pass sees the belt through the clear bottle
    assert farther.sum() > 100 and np.array_equal(own[~farther], depths[~farther])


def test_a_cameras_scene_leaves_out_only_the_geoms_out_of_its_view(cell_with_items):
    """`geoms_out_of_view` names the geoms whose bounding sphere lies wholly outside the
    canvas: the robot and its bins downstream, never the items under the camera, the belt or
    the floor (a plane is never left out)."""
    model, data = cell_with_items
    cam = camera_id(model)
    focal = true_camera_matrix(model, 640, 360)[1, 1]
    out = set(geoms_out_of_view(model, data, cam, (640, 360), focal).tolist())
    names = ("base_housing", "platform_plate", "bin_paper_stand", "belt", "floor")
    robot, platform, bin_stand, belt, floor = (
        mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name) for name in names
    )
    assert {robot, platform, bin_stand} <= out
    items = set(range(model.ngeom - 3, model.ngeom))  # the fixture's can, tray and bottle
    assert not (items | {belt, floor}) & out


def test_frames_with_depth_leave_out_only_a_sky_nobody_sees(cell_with_items, fixture_model):
    """The colour pass of a frame with depth draws the skybox only when the depth pass leaves
    some pixel to the sky: in the cell the belt and the floor hide it, and the frame is the
    same as one drawn with it; the fixture (a belt in the void) keeps it."""
    for (model, data), sky_seen in ((cell_with_items, False), (fixture_model, True)):
        with BeltCamera(model, 640, 360) as camera:
            frame, _ = camera.render_rgbd(data)
            assert bool(camera._passes._renderer.scene.flags[SKYBOX]) == sky_seen
            assert np.array_equal(frame, camera.render(data))


def test_a_camera_renders_at_its_own_sample_count(cell_with_items):
    """`samples` sets the colour pass's multisampling, the model's count by default; the depth
    and the model's own setting do not change."""
    model, data = cell_with_items
    own = model.vis.quality.offsamples
    with BeltCamera(model, 640, 360) as default, BeltCamera(model, 640, 360, samples=0) as none:
        assert default.samples == own and none.samples == 0
        (frame, depth), (plain, plain_depth) = default.render_rgbd(data), none.render_rgbd(data)
    assert model.vis.quality.offsamples == own
    assert np.array_equal(depth, plain_depth)
    edges = np.any(frame != plain, axis=2)
    assert 0 < edges.mean() < 0.05  # the multisampled frame differs only along edges


def test_a_window_is_the_whole_frame_cut_to_it(cell_with_items, fixture_model):
    """`BeltCamera.window` renders only the part of the canvas its pixels sample: the same
    colours and depths as the whole frame's window (the depth within the rasteriser's float
    rounding), the can, the tray and the clear bottle in it; one window object per window."""
    rows, cols = slice(105, 254), slice(126, 514)
    for model, data in (cell_with_items, fixture_model):
        with BeltCamera(model, 640, 360, samples=0) as camera:
            frame, depth = camera.render_rgbd(data)
            window = camera.window(rows, cols)
            assert camera.window(slice(105, 254), slice(126, 514)) is window
            crop, crop_depth = window.render_rgbd(data)
            assert crop.shape == frame[rows, cols].shape and crop_depth.dtype == np.float32
            assert np.abs(crop.astype(int) - frame[rows, cols]).max() <= 1
            assert np.abs(crop_depth - depth[rows, cols]).max() < 1e-5
            assert np.ptp(crop_depth) > 0.005  # items stand out of the belt in the window
    with BeltCamera(*cell_with_items[:1], 640, 360) as camera, pytest.raises(InvalidInput):
        camera.window(slice(300, 400), slice(0, 10))


def test_lens_maps_are_kept_between_processes_under_what_makes_them(tmp_path, monkeypatch):
    """`cached_distorter` keeps a frame's lens maps in the user's cache folder under the digest
    of what they depend on: a later camera reads the same maps byte for byte, another lens or
    window makes its own, and a damaged file is made again."""
    from perception.camera.lens import (
        ZED_HD_LEFT,
        LensDistorter,
        LensModel,
        source_canvas,
        window_source,
    )
    from sim.cell import camera

    monkeypatch.setenv("SORTSIM_CACHE_DIR", str(tmp_path))
    matrix = np.array([[311.77, 0.0, 319.5], [0.0, 311.77, 179.5], [0.0, 0.0, 1.0]])
    src_matrix, src_size = source_canvas(matrix, ZED_HD_LEFT, (640, 360))
    args = (matrix, ZED_HD_LEFT, (640, 360), src_matrix, src_size)
    made = LensDistorter(*args)
    first = camera.cached_distorter(*args)
    (kept,) = tmp_path.glob("lens_maps-*.npz")
    again = camera.cached_distorter(*args)
    for distorter in (first, again):
        assert distorter._map1.tobytes() == made._map1.tobytes()
        assert distorter._map2.tobytes() == made._map2.tobytes()
    window = (slice(100, 200), slice(50, 600))
    part_matrix, part, _ = window_source(matrix, ZED_HD_LEFT, src_matrix, window)
    camera.cached_distorter(matrix, ZED_HD_LEFT, (640, 360), part_matrix, part, window)
    other = LensModel(k1=-0.1)
    camera.cached_distorter(matrix, other, (640, 360), *source_canvas(matrix, other, (640, 360)))
    assert len(list(tmp_path.glob("lens_maps-*.npz"))) == 3
    kept.write_bytes(b"not maps")
    remade = camera.cached_distorter(*args)
    assert remade._map1.tobytes() == made._map1.tobytes()
    assert camera.cached_distorter(*args)._map2.tobytes() == made._map2.tobytes()
    assert not list(tmp_path.glob(".*"))  # no temporary left
