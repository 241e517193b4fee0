"""Items from camera pixels: one blob per item, classed by the cells' posteriors."""

from __future__ import annotations

import numpy as np

from perception.items.blobs import item_blobs

ROWS, STRIPES = 6, 5


def _empty():
    return [[np.zeros(0) for _ in range(STRIPES)] for _ in range(ROWS)]


def _rectangle(b0, b1, y0, y1, step=0.002):
    b, y = np.meshgrid(np.arange(b0, b1, step), np.arange(y0, y1, step), indexing="ij")
    return b.ravel(), y.ravel()


def test_two_items_two_blobs_with_their_centroids_and_classes():
    pixel_b, pixel_y = _empty(), _empty()
    posteriors = np.zeros((ROWS, STRIPES, 4))
    posteriors[..., 0] = 1.0
    # A can spanning two rows of stripe 1 (cells decode to aluminium and, wrongly, paper).
    b, y = _rectangle(0.10, 0.16, -0.20, -0.14)
    for r, sel in ((1, b < 0.13), (2, b >= 0.13)):
        pixel_b[r][1], pixel_y[r][1] = b[sel], y[sel]
    posteriors[1, 1] = [0.0, 0.1, 0.0, 0.9]
    posteriors[2, 1] = [0.0, 0.6, 0.0, 0.4]
    # A bottle in stripe 3, row 4.
    b2, y2 = _rectangle(0.40, 0.46, 0.10, 0.16)
    pixel_b[4][3], pixel_y[4][3] = b2, y2
    posteriors[4, 3] = [0.1, 0.0, 0.9, 0.0]
    # Three stray pixels: noise, dropped.
    pixel_b[5][0], pixel_y[5][0] = np.array([0.6, 0.602, 0.604]), np.array([-0.35] * 3)

    blobs = sorted(item_blobs(pixel_b, pixel_y, posteriors), key=lambda blob: blob.b)
    assert len(blobs) == 2
    can, bottle = blobs
    assert abs(can.b - 0.129) < 2e-3 and abs(can.y + 0.171) < 2e-3
    np.testing.assert_allclose(can.probs, [0.0, 0.35, 0.0, 0.65], atol=0.02)
    assert can.last_row == 2
    assert abs(bottle.b - 0.429) < 2e-3 and abs(bottle.y - 0.129) < 2e-3
    np.testing.assert_allclose(bottle.probs, [0.0, 0.0, 1.0, 0.0], atol=1e-12)
    assert bottle.last_row == 4


def test_no_pixels_no_blobs():
    assert item_blobs(_empty(), _empty(), np.zeros((ROWS, STRIPES, 4))) == []
