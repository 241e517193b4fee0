"""Touching items cut apart by the footprint's shape and the steps in height between them."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from scipy import ndimage

from perception.camera.calibration import CameraCalibration
from perception.camera.grid import BeltGrid
from perception.camera.observe import BELT
from perception.camera.pipeline import CameraPipeline
from perception.errors import PerceptionInputError
from perception.items.blobs import item_blobs
from perception.items.split import SplitSettings, split_region
from sim.cell.camera import BeltCamera, marker_points
from sim.cli.calibrate import DEFAULT_CALIBRATION
from sim.flow.catalogue import load_catalogue
from sim.paths import SCENE_XML

PITCH = 0.002  # the footprint raster's pixel [m]


def _grid(half: float) -> tuple[np.ndarray, np.ndarray]:
    """Pixel centres of a square [-half, half]^2 [m] on the footprint's 2 mm pitch."""
    axis = np.arange(-half, half + 1e-9, PITCH) + 0.0003  # off the raster's cell edges
    b, y = np.meshgrid(axis, axis, indexing="ij")
    return b.ravel(), y.ravel()


def _disc(cb: float, cy: float, radius: float) -> tuple[np.ndarray, np.ndarray]:
    b, y = _grid(radius)
    inside = b * b + y * y <= radius * radius
    return b[inside] + cb, y[inside] + cy


def _centroids(b, y, piece, count):
    return sorted((b[piece == k].mean(), y[piece == k].mean()) for k in range(count))


def test_touching_discs_of_different_heights_are_two_items():
    """A yoghurt pot (r 35 mm, 45 mm tall) and a standing can (r 33 mm, 115 mm tall) whose
    footprints overlap by 18 mm, as a tall item leans into its neighbour's view: the neck is
    too wide for the shape alone, the 70 mm step in height cuts them apart."""
    pot_b, pot_y = _disc(0.0, 0.0, 0.035)
    can_b, can_y = _disc(0.050, 0.0, 0.033)
    pot = (pot_b - 0.050) ** 2 + pot_y**2 > 0.033**2  # the can hides the overlap
    b = np.r_[pot_b[pot], can_b]
    y = np.r_[pot_y[pot], can_y]
    height = np.r_[np.full(pot.sum(), 0.045), np.full(can_b.size, 0.115)]

    piece, count = split_region(b, y, height)
    assert count == 2
    expected = sorted([(pot_b[pot].mean(), pot_y[pot].mean()), (can_b.mean(), can_y.mean())])
    for got, want in zip(_centroids(b, y, piece, count), expected, strict=True):
        assert math.dist(got, want) < 0.002
    # Most pixels go to their own item (the wall between them is one 3 mm cell wide).
    assert np.mean(piece[height > 0.1] == piece[height > 0.1][0]) > 0.97
    assert np.mean(piece[height < 0.1] != piece[height > 0.1][0]) > 0.95
    # Without depth the footprint alone is one item: the heights did it.
    assert split_region(b, y, None)[1] == 1


def test_touching_discs_of_one_height_split_at_their_neck():
    """Two standing cans (r 33 mm) 2 mm apart with a 10 mm wide bridge of pixels between them
    (rims that blend): same height, so the neck of the footprint decides."""
    left_b, left_y = _disc(0.0, 0.0, 0.033)
    right_b, right_y = _disc(0.068, 0.0, 0.033)
    bb, by = np.meshgrid(np.arange(0.025, 0.043, PITCH), np.arange(-0.005, 0.005, PITCH))
    b = np.r_[left_b, right_b, bb.ravel()] + 5.0
    y = np.r_[left_y, right_y, by.ravel()] - 0.2
    height = np.full(b.size, 0.115)

    piece, count = split_region(b, y, height)
    assert count == 2
    centres = _centroids(b, y, piece, count)
    assert math.dist(centres[0], (5.0, -0.2)) < 0.002
    assert math.dist(centres[1], (5.068, -0.2)) < 0.002


@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, 90.0])
def test_a_lying_bottle_and_an_a4_sheet_stay_whole(yaw_deg):
    """A lying 1.5 L bottle (310 x 90 mm, a rounded top 45..90 mm high) and an A4 sheet
    (297 x 210 mm, 2 mm high) are one item each, at any heading."""
    yaw = math.radians(yaw_deg)
    b, y = _grid(0.16)
    along = b * math.cos(yaw) + y * math.sin(yaw)
    across = -b * math.sin(yaw) + y * math.cos(yaw)
    over = np.maximum(np.abs(along) - 0.11, 0.0)
    bottle = over**2 + across**2 <= 0.045**2
    reach = np.sqrt(np.maximum(0.045**2 - over**2 - across**2, 0.0))
    piece, count = split_region(b[bottle], y[bottle], 0.045 + reach[bottle])
    assert count == 1
    assert abs(b[bottle].mean()) < 0.002 and abs(y[bottle].mean()) < 0.002

    sheet = (np.abs(along) <= 0.1485) & (np.abs(across) <= 0.105)
    piece, count = split_region(b[sheet], y[sheet], np.full(sheet.sum(), 0.002))
    assert count == 1


def test_item_blobs_split_touching_items_and_keep_the_old_blobs_without_settings():
    """Through `item_blobs`: the can and the pot of the first test, spread over two rows of one
    stripe, are one 8-connected blob without split settings and two with them."""
    pot_b, pot_y = _disc(0.0, 0.0, 0.035)
    can_b, can_y = _disc(0.050, 0.0, 0.033)
    pot = (pot_b - 0.050) ** 2 + pot_y**2 > 0.033**2
    b = np.r_[pot_b[pot], can_b] + 3.0
    y = np.r_[pot_y[pot], can_y]
    h = np.r_[np.full(pot.sum(), 0.045), np.full(can_b.size, 0.115)]
    first = b < 3.03
    pixel_b = [[b[first]], [b[~first]]]
    pixel_y = [[y[first]], [y[~first]]]
    pixel_h = [[h[first]], [h[~first]]]
    posteriors = np.zeros((2, 1, 4))
    posteriors[..., 3] = 1.0

    whole = item_blobs(pixel_b, pixel_y, posteriors, pixel_height=pixel_h)
    assert len(whole) == 1 and whole[0].pixels == b.size
    split = item_blobs(pixel_b, pixel_y, posteriors, pixel_height=pixel_h, split=SplitSettings())
    assert len(split) == 2
    pot_blob, can_blob = sorted(split, key=lambda blob: blob.b)
    assert math.dist((pot_blob.b, pot_blob.y), (pot_b[pot].mean() + 3.0, pot_y[pot].mean())) < 0.002
    assert math.dist((can_blob.b, can_blob.y), (can_b.mean() + 3.0, can_y.mean())) < 0.002
    assert pot_blob.last_row == 0 and can_blob.last_row == 1
    np.testing.assert_allclose(can_blob.probs, [0.0, 0.0, 0.0, 1.0], atol=1e-12)
    # `members` index the window's pixels, row by row.
    all_b = np.r_[b[first], b[~first]]
    assert np.allclose(all_b[can_blob.members].mean(), can_blob.b, atol=1e-12)


def test_blobs_do_not_depend_on_the_rest_of_the_window():
    """The raster is fixed on the belt: a pot and a can 5 mm apart are cut and found the same
    way whatever else the window holds (here a scrap 0.5 m away, in the oldest row), so a
    region seen complete once is never found again with new neighbours."""
    pot_b, pot_y = _disc(0.0, 0.0, 0.035)
    can_b, can_y = _disc(0.073, 0.004, 0.033)
    b = np.r_[pot_b, can_b] + 7.0
    y = np.r_[pot_y, can_y]
    h = np.r_[np.full(pot_b.size, 0.045), np.full(can_b.size, 0.115)]
    posteriors = np.full((3, 1, 4), 0.25)
    settings = SplitSettings()
    found = []
    for shift in np.arange(0.0, 0.006, 0.001):
        scrap_b, scrap_y = _grid(0.02)
        pixel_b = [[scrap_b + 6.5 - shift], [b[b < 7.04]], [b[b >= 7.04]]]
        pixel_y = [[scrap_y + 0.1 + shift], [y[b < 7.04]], [y[b >= 7.04]]]
        pixel_h = [[np.full(scrap_b.size, 0.002)], [h[b < 7.04]], [h[b >= 7.04]]]
        blobs = item_blobs(
            pixel_b, pixel_y, posteriors, pixel_height=pixel_h, split=settings, complete_row=2
        )
        found.append(sorted((round(blob.b, 9), round(blob.y, 9)) for blob in blobs))
    assert len(found[0]) == 2
    assert all(f == found[0] for f in found)
    assert math.dist(found[0][0], (pot_b.mean() + 7.0, pot_y.mean())) < 0.001
    assert math.dist(found[0][1], (can_b.mean() + 7.0, can_y.mean())) < 0.001


def test_refusals():
    with pytest.raises(PerceptionInputError, match="raster_m"):
        SplitSettings(raster_m=0.1)
    with pytest.raises(PerceptionInputError, match="neck_ratio"):
        SplitSettings(neck_ratio=0.0)
    with pytest.raises(PerceptionInputError, match="step_m"):
        SplitSettings(step_m=-0.01)
    piece, count = split_region(np.zeros(0), np.zeros(0))
    assert piece.size == 0 and count == 0


def test_a_can_beside_a_tray_in_the_rendered_frame_is_two_items():
    """The real camera path: a standing can (115 mm) 2 mm beside a foil tray (30 mm) under the
    belt camera, frame and depth map rendered, footprints and heights from
    `FootprintMapper`; on the 6 mm raster they are one region, the split finds both at their
    true centres."""
    catalogue = load_catalogue()
    spec = mujoco.MjSpec.from_file(str(SCENE_XML))
    items = {
        "can": ((-1.47, -0.06, 0.0575), mujoco.mjtGeom.mjGEOM_CYLINDER, [0.033, 0.0575, 0]),
        "tray": ((-1.47, 0.050, 0.015), mujoco.mjtGeom.mjGEOM_BOX, [0.1, 0.075, 0.015]),
    }
    colours = {"can": "red", "tray": "white"}
    for name, (pos, kind, size) in items.items():
        body = spec.worldbody.add_body(pos=list(pos))
        rgba = list(catalogue.colour_rgba(colours[name]))
        body.add_geom(type=kind, size=size, contype=0, conaffinity=0, rgba=rgba)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    size = (640, 360)
    with BeltCamera(model, *size) as camera:
        frame, depth = camera.render_rgbd(data)
    calibration = CameraCalibration.load(DEFAULT_CALIBRATION).scaled(size)
    pipeline = CameraPipeline(calibration, BeltGrid(), *marker_points(model, data))
    pipeline.locate(frame)
    labels, height, _ = pipeline.mapper.footprint_and_height(frame, depth, pipeline.rules)
    rows, cols = np.nonzero(labels != BELT)
    xy = pipeline.raster.pixel_to_world(rows, cols)
    b, y, h = -xy[:, 0], xy[:, 1], height[rows, cols].astype(float)

    one = item_blobs([[b]], [[y]], np.full((1, 1, 4), 0.25))
    assert len(one) == 1  # the 8-connected regions merge them
    piece, count = split_region(b, y, h)
    assert count == 2
    centres = [(b[piece == k].mean(), y[piece == k].mean()) for k in range(count)]
    for name, (pos, _, _) in items.items():
        true_centre = (-pos[0], pos[1])
        nearest = min(range(count), key=lambda k: math.dist(true_centre, centres[k]))
        assert math.dist(true_centre, centres[nearest]) < 0.004, name
        assert abs(np.median(h[piece == nearest]) - 2 * pos[2]) < 0.004, name


def _rect(cb: float, cy: float, half_b: float, half_y: float) -> tuple[np.ndarray, np.ndarray]:
    b, y = _grid(max(half_b, half_y))
    inside = (np.abs(b) <= half_b) & (np.abs(y) <= half_y)
    return b[inside] + cb, y[inside] + cy


def _stadium(cb: float, cy: float, half_straight: float, radius: float):
    """A lying bottle along the belt: pixels and their rounded heights (radius..2 radius)."""
    b, y = _grid(half_straight + radius)
    over = np.maximum(np.abs(b) - half_straight, 0.0)
    inside = over**2 + y**2 <= radius**2
    height = radius + np.sqrt(np.maximum(radius**2 - over**2 - y**2, 0.0))
    return b[inside] + cb, y[inside] + cy, height[inside]


def _clutter(rng: np.random.Generator):
    """A busy belt's cluster of five touching items, each item's pixels labelled 0..4: a
    carton (110 x 80 mm, 54 mm tall) with a yoghurt pot (r 35 mm, 52 mm) pressed 8 mm into
    its long side (one height, a neck 51 mm wide: the neck test alone keeps them whole), a
    lying 0.5 l bottle (32..64 mm high) against its other side, offset by 70 mm, a standing
    can (r 33 mm, 115 mm) at the bottle's end and a crushed can (60 x 60 mm, 24 mm) beside
    the standing can. Heights carry 3 mm of noise. Where footprints overlap the item listed
    later lies on top."""
    items = [
        (*_rect(0.0, 0.0, 0.055, 0.040), 0.054),
        (*_disc(0.0, 0.040 + 0.035 - 0.008, 0.035), 0.052),
        _stadium(0.070, -0.040 - 0.032 + 0.004, 0.055, 0.032),
        (*_disc(0.070 + 0.087 + 0.033 - 0.004, -0.068, 0.033), 0.115),
        (*_rect(0.190, -0.068 + 0.033 + 0.030 - 0.004, 0.030, 0.030), 0.024),
    ]
    b, y, h, label = [], [], [], []
    for k, (ib, iy, ih) in enumerate(items):
        b.append(ib)
        y.append(iy)
        h.append(np.broadcast_to(ih, ib.shape))
        label.append(np.full(ib.size, k))
    b, y, h, label = (np.concatenate(a) for a in (b, y, h, label))
    # What the camera sees from above: at each 2 mm pixel the item listed last.
    key = np.round(b / PITCH).astype(np.int64) * 100000 + np.round(y / PITCH).astype(np.int64)
    order = np.lexsort((-label, key))
    first = np.r_[True, key[order][1:] != key[order][:-1]]
    keep = order[first]
    h = h[keep] + rng.normal(0.0, 0.003, keep.size)
    return b[keep] + 2.0, y[keep] - 0.1, h, label[keep]


def test_a_cluster_of_five_touching_items_is_cut_into_five():
    """The shipped split on a synthetic busy-belt cluster (`_clutter`): five pieces, each
    true item's pixels at least 85 % in its own piece (the cut is a straight chord: the pot's
    cap pressed over the carton goes to the carton), every centroid within 5 mm of its item's
    visible pixels' centroid. Without the cuts at concave notches (the split before
    busy belts) the carton and the pot stay one item."""
    from sim.sensing.perception import ITEM_SPLIT

    rng = np.random.default_rng(7)
    b, y, h, label = _clutter(rng)
    piece, count = split_region(b, y, h, ITEM_SPLIT)
    assert count == 5
    for k in range(5):
        mine = label == k
        main = np.bincount(piece[mine], minlength=count).argmax()
        assert np.mean(piece[mine] == main) >= 0.85, k
        got = (b[piece == main].mean(), y[piece == main].mean())
        assert math.dist(got, (b[mine].mean(), y[mine].mean())) < 0.005, k
    before = SplitSettings(step_m=ITEM_SPLIT.step_m)
    assert split_region(b, y, h, before)[1] < 5


@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, 90.0])
def test_single_items_stay_whole_with_the_cuts_at_notches(yaw_deg):
    """Convex items alone (a lying 1.5 l bottle, an A4 sheet, a carton, a standing can), their
    outlines ragged (a pixel in three missing along a 4 mm rim) and their heights noisy by
    3 mm: one piece each with the shipped split."""
    from sim.sensing.perception import ITEM_SPLIT

    rng = np.random.default_rng(int(yaw_deg))
    yaw = math.radians(yaw_deg)
    b, y = _grid(0.16)
    along = b * math.cos(yaw) + y * math.sin(yaw)
    across = -b * math.sin(yaw) + y * math.cos(yaw)
    over = np.maximum(np.abs(along) - 0.11, 0.0)
    shapes = {
        "bottle": (
            over**2 + across**2 <= 0.045**2,
            0.045 + np.sqrt(np.maximum(0.045**2 - over**2 - across**2, 0.0)),
        ),
        "sheet": ((np.abs(along) <= 0.1485) & (np.abs(across) <= 0.105), np.full(b.size, 0.002)),
        "carton": ((np.abs(along) <= 0.055) & (np.abs(across) <= 0.04), np.full(b.size, 0.054)),
        "can": (along**2 + across**2 <= 0.033**2, np.full(b.size, 0.115)),
    }
    for name, (inside, height) in shapes.items():
        rim = ndimage.binary_dilation(~inside.reshape(161, 161), iterations=2).ravel()
        keep = inside & ~(rim & (rng.random(b.size) < 1 / 3))
        noisy = height[keep] + rng.normal(0.0, 0.003, keep.sum())
        assert split_region(b[keep], y[keep], noisy, ITEM_SPLIT)[1] == 1, name


def test_a_chain_of_touching_items_longer_than_the_window_is_found_item_by_item():
    """Twenty standing cans (r 33 mm), each touching the next, in a line along the belt 1.3 m
    long: one region longer than the 12-row window (1.1 m at x1), which would never be
    complete. With the window's reported pixels kept, every can is found exactly once, at its
    centre within 3 mm, as its rows pass; without them the cans that left the window before
    the chain ended are never found."""
    from sim.sensing.perception import COMPLETE_ROW, ITEM_SPLIT, WINDOW_ROWS

    row_m = 0.185 * 0.5
    centres = 0.2 + 0.065 * np.arange(20)
    b = np.concatenate([_disc(c, 0.0, 0.033)[0] for c in centres])
    y = np.concatenate([_disc(c, 0.0, 0.033)[1] for c in centres])
    h = np.full(b.size, 0.115)
    stream = np.floor(b / row_m).astype(int)
    rows = int(stream.max()) + WINDOW_ROWS + 1
    posteriors = np.full((WINDOW_ROWS, 1, 4), 0.25)

    def run(keep_reported: bool) -> list:
        window = [[np.zeros(0)]] * WINDOW_ROWS
        window_y, window_h = list(window), list(window)
        done = [[np.zeros(0, bool)]] * WINDOW_ROWS
        found = []
        for r in range(rows):
            mine = stream == r
            window = window[1:] + [[b[mine]]]
            window_y = window_y[1:] + [[y[mine]]]
            window_h = window_h[1:] + [[h[mine]]]
            done = done[1:] + [[np.zeros(int(mine.sum()), bool)]]
            found += item_blobs(
                window, window_y, posteriors, pixel_height=window_h, split=ITEM_SPLIT,
                complete_row=COMPLETE_ROW, reported=done if keep_reported else None,
            )  # fmt: skip
        return sorted(blob.b for blob in found)

    found = run(keep_reported=True)
    assert len(found) == 20
    np.testing.assert_allclose(found, centres, atol=0.003)
    assert len(run(keep_reported=False)) < 20


def test_pieces_of_one_convex_item_are_joined_again_and_touching_items_are_not():
    """The rejoining step on a cut raster: a lying bottle's stadium cut across its body into two
    pieces (as the distance transform cut a bottle whose end met a neighbour) is one piece
    again; the pot pressed against it (a notch 12 mm deep or more between them) and a can of
    another height beside it stay apart."""
    from perception.items.split import _rejoin
    from sim.sensing.perception import ITEM_SPLIT

    cells = np.zeros((120, 90), np.int64)
    rows, cols = np.mgrid[:120, :90]
    over = np.maximum(np.abs(rows - 50) - 35, 0)
    bottle = over**2 + (cols - 30) ** 2 <= 15**2  # 3 mm cells: 300 x 90 mm
    cells[bottle & (rows < 40)] = 1
    cells[bottle & (rows >= 40)] = 2
    pot = ((rows - 50) ** 2 + (cols - 55) ** 2 <= 12**2) & ~bottle
    cells[pot] = 3
    can = ((rows - 105) ** 2 + (cols - 30) ** 2 <= 11**2) & ~bottle
    cells[can] = 4
    top = np.where(bottle, 0.07, 0.0) + np.where(pot, 0.06, 0.0) + np.where(can, 0.125, 0.0)

    joined = _rejoin(cells, top.astype(np.float32), ITEM_SPLIT)
    assert joined.max() == 3
    assert len(np.unique(joined[bottle])) == 1
    assert len({joined[bottle][0], joined[pot][0], joined[can][0]}) == 3
