"""The stereo depth error model: its size, growth with range, correlation and edge holes."""

import numpy as np
import pytest

from sim.cell.depth_noise import ZED_CLASS, StereoDepthNoise
from sim.errors import InvalidInput


def _error(z: float, noise=ZED_CLASS, seed=0, shape=(240, 320)) -> np.ndarray:
    depth = np.full(shape, z, dtype=np.float32)
    return noise.apply(depth, np.random.default_rng(seed)) - depth


def test_error_is_one_percent_of_range_at_the_belt():
    err = _error(0.75)
    assert abs(float(np.mean(err))) < 0.0005  # unbiased [m]
    assert float(np.std(err)) == pytest.approx(0.0075, rel=0.1)


def test_error_grows_with_the_square_of_range_beyond_the_reference():
    assert float(np.std(_error(1.5))) == pytest.approx(0.01 * 1.5 * 2.0, rel=0.1)
    assert float(np.std(_error(0.6))) == pytest.approx(0.006, rel=0.1)


def test_neighbouring_pixels_err_together():
    err = _error(0.75)
    r = np.corrcoef(err[:, :-1].ravel(), err[:, 1:].ravel())[0, 1]
    assert 0.4 < r < 0.9  # block matching: correlated, with a per-pixel part


def test_holes_only_along_depth_steps():
    depth = np.full((100, 100), 0.75, dtype=np.float32)
    depth[:, 50:] = 0.68  # a 7 cm tall item's top beside the belt
    out = StereoDepthNoise().apply(depth, np.random.default_rng(1))
    holes = np.isnan(out)
    assert not holes[:, :48].any() and not holes[:, 52:].any()
    share = holes[:, 49:51].mean()
    assert share == pytest.approx(0.6, abs=0.08)


def test_invalid_depth_stays_invalid_and_same_seed_same_map():
    depth = np.full((50, 50), 0.75, dtype=np.float32)
    depth[10, 10] = 0.0
    depth[20, 20] = np.inf
    a = ZED_CLASS.apply(depth, np.random.default_rng(3))
    b = ZED_CLASS.apply(depth, np.random.default_rng(3))
    assert np.isnan(a[10, 10]) and np.isnan(a[20, 20])
    assert np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize(
    ("field", "value"),
    [("relative_error", -0.1), ("white_share", 1.5), ("correlation_px", 0.0), ("edge_step_m", 0.0)],
)
def test_bad_settings_are_refused_naming_the_field(field, value):
    with pytest.raises(InvalidInput, match=field):
        StereoDepthNoise(**{field: value})
