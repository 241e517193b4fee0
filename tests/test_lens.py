"""The lens model: distortion of pinhole images, checked against OpenCV's forward projection."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from perception.camera.lens import (
    ZED_HD_LEFT,
    LensDistorter,
    LensModel,
    source_canvas,
    window_source,
)
from perception.errors import PerceptionInputError

SIZE = (640, 360)
MATRIX = np.array([[311.77, 0.0, 319.5], [0.0, 311.77, 179.5], [0.0, 0.0, 1.0]])


def _distorter(lens: LensModel = ZED_HD_LEFT) -> LensDistorter:
    src_matrix, src_size = source_canvas(MATRIX, lens, SIZE)
    return LensDistorter(MATRIX, lens, SIZE, src_matrix, src_size)


def test_zed_coefficients_are_a_wide_barrel_lens():
    coeffs = ZED_HD_LEFT.dist_coeffs()
    assert coeffs.shape == (5,)
    assert -0.2 < coeffs[0] < -0.14 and 0.0 < coeffs[1] < 0.05


@pytest.mark.parametrize("field", ["k1", "k2", "p1", "p2", "k3"])
def test_lens_refuses_wild_coefficients(field):
    with pytest.raises(PerceptionInputError, match=f"lens.{field}"):
        LensModel(**{field: 3.0})
    with pytest.raises(PerceptionInputError):
        LensModel(**{field: float("nan")})


def test_source_canvas_holds_every_ray_of_the_distorted_frame():
    src_matrix, (src_w, src_h) = source_canvas(MATRIX, ZED_HD_LEFT, SIZE)
    assert src_matrix[0, 0] == MATRIX[0, 0]
    # Barrel distortion: the corners see rays from well outside the pinhole frame.
    assert src_w > SIZE[0] * 1.2 and src_h > SIZE[1] * 1.2
    corner = np.array([[[0.0, 0.0]]])
    norm = cv2.undistortPoints(corner, MATRIX, ZED_HD_LEFT.dist_coeffs()).reshape(2)
    u = src_matrix[0, 0] * norm[0] + src_matrix[0, 2]
    v = src_matrix[1, 1] * norm[1] + src_matrix[1, 2]
    assert 0.0 <= u < src_w and 0.0 <= v < src_h


def test_dots_land_where_opencv_projects_them():
    src_matrix, (src_w, src_h) = source_canvas(MATRIX, ZED_HD_LEFT, SIZE)
    rng = np.random.default_rng(3)
    rays = np.c_[rng.uniform(-0.9, 0.9, 12), rng.uniform(-0.5, 0.5, 12), np.ones(12)]
    expected, _ = cv2.projectPoints(
        rays, np.zeros(3), np.zeros(3), MATRIX, ZED_HD_LEFT.dist_coeffs()
    )
    expected = expected.reshape(-1, 2)
    distorter = _distorter()
    for ray, target in zip(rays, expected, strict=True):
        # A smooth blob on the pinhole canvas where the ray lands.
        u0 = src_matrix[0, 0] * ray[0] + src_matrix[0, 2]
        v0 = src_matrix[1, 1] * ray[1] + src_matrix[1, 2]
        uu, vv = np.meshgrid(np.arange(src_w), np.arange(src_h))
        blob = np.exp(-((uu - u0) ** 2 + (vv - v0) ** 2) / (2 * 3.0**2))
        pinhole = np.repeat((255 * blob).astype(np.uint8)[..., None], 3, axis=2)
        out = distorter.apply(pinhole)[..., 0].astype(np.float64)
        weight = np.where(out > 20, out, 0.0)
        v, u = np.nonzero(weight)
        centre = np.array(
            [np.average(u, weights=weight[v, u]), np.average(v, weights=weight[v, u])]
        )
        # The blob shrinks anisotropically under distortion, so its centroid moves by a little.
        assert np.linalg.norm(centre - target) < 0.3


def test_distortion_is_real_and_undistortion_undoes_it():
    src_matrix, (src_w, src_h) = source_canvas(MATRIX, ZED_HD_LEFT, SIZE)
    # A pinhole image of straight lines: a grid of 1-px-wide lines every 40 px.
    pinhole = np.zeros((src_h, src_w, 3), np.uint8)
    off_u, off_v = int(src_matrix[0, 2] - MATRIX[0, 2]), int(src_matrix[1, 2] - MATRIX[1, 2])
    pinhole[off_v : off_v + SIZE[1], off_u : off_u + SIZE[0]] = 60
    for k in range(0, SIZE[0], 40):
        pinhole[:, off_u + k] = 255
    distorted = _distorter().apply(pinhole)
    straight = pinhole[off_v : off_v + SIZE[1], off_u : off_u + SIZE[0]]
    assert np.mean(np.abs(distorted.astype(int) - straight)) > 10
    restored = cv2.undistort(distorted, MATRIX, ZED_HD_LEFT.dist_coeffs())
    centre = (slice(40, SIZE[1] - 40), slice(60, SIZE[0] - 60))
    diff = np.abs(restored[centre].astype(int) - straight[centre].astype(int))
    assert np.mean(diff) < 6


def test_distorter_refuses_a_pinhole_image_of_another_size():
    with pytest.raises(PerceptionInputError, match="pinhole image shape"):
        _distorter().apply(np.zeros((SIZE[1], SIZE[0], 3), np.uint8))


@pytest.mark.parametrize(
    "window", [(slice(105, 254), slice(126, 514)), (slice(0, 40), slice(600, 640))]
)
def test_a_window_samples_the_same_rays_from_a_part_of_the_canvas(window):
    """`window_source`'s part of the canvas is centred on it an integer number of pixels in,
    holds every ray the window samples, and the window's distortion of the part equals the
    whole image's distortion of the canvas, cut to the window (an off-centre window too)."""
    src_matrix, src_size = source_canvas(MATRIX, ZED_HD_LEFT, SIZE)
    matrix, size, offset = window_source(MATRIX, ZED_HD_LEFT, src_matrix, window)
    assert size[0] < src_size[0] and size[1] < src_size[1]
    assert offset == ((src_size[0] - size[0]) // 2, (src_size[1] - size[1]) // 2)
    assert (src_size[0] - size[0]) % 2 == 0 and (src_size[1] - size[1]) % 2 == 0
    assert matrix[0, 0] == src_matrix[0, 0]
    # Images of the canvas's own pixel coordinates: a distortion samples them where it reads.
    uu, vv = np.meshgrid(np.arange(src_size[0], dtype=np.float32), np.arange(src_size[1]))
    whole_lens = LensDistorter(MATRIX, ZED_HD_LEFT, SIZE, src_matrix, src_size)
    cut_lens = LensDistorter(MATRIX, ZED_HD_LEFT, SIZE, matrix, size, window)
    for image, shift in ((uu, offset[0]), (vv.astype(np.float32), offset[1])):
        part = image[offset[1] : offset[1] + size[1], offset[0] : offset[0] + size[0]] - shift
        cut = cut_lens.apply(np.ascontiguousarray(part)) + shift
        assert cut.shape == whole_lens.apply(image)[window].shape
        # Both read the same canvas point, to the maps' fixed-point step (1/32 px).
        assert np.abs(cut - whole_lens.apply(image)[window]).max() <= 1.0 / 16.0


def test_window_source_refuses_an_empty_window():
    src_matrix, _ = source_canvas(MATRIX, ZED_HD_LEFT, SIZE)
    with pytest.raises(PerceptionInputError, match="window"):
        window_source(MATRIX, ZED_HD_LEFT, src_matrix, (slice(10, 10), slice(0, 5)))
