"""Saving and loading the stripe HMMs: round trip and one-line refusals of bad files."""

from __future__ import annotations

import numpy as np
import pytest

from perception.errors import PerceptionInputError
from perception.hmm.storage import FORMAT, VERSION, load_models, save_models
from perception.hmm.training import count_models


@pytest.fixture
def models():
    rng = np.random.default_rng(0)
    cls = rng.integers(1, 5, size=(60, 5))
    codes = rng.integers(1, 20, size=(60, 5))
    return count_models([cls], [codes], coupled=True)


def test_round_trip_is_exact(tmp_path, models):
    path = save_models(tmp_path / "stripes", models)
    assert path.suffix == ".npz"
    back = load_models(path, coupled=True)
    for name in ("pi", "A", "B"):
        assert np.array_equal(getattr(back, name), getattr(models, name))
    with pytest.raises(PerceptionInputError, match="A of shape"):
        load_models(path, coupled=False)


def _write(path, **overrides):
    arrays = {
        "format": np.array(FORMAT),
        "version": np.array(VERSION),
        "pi": np.full((5, 4), 0.25),
        "A": np.full((5, 1, 4, 4), 0.25),
        "B": np.full((5, 4, 19), 1 / 19),
    }
    arrays.update(overrides)
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None})
    return path


@pytest.mark.parametrize(
    ("overrides", "needle"),
    [
        ({"version": np.array(VERSION + 1)}, "format version"),
        ({"format": np.array("other")}, "format"),
        ({"B": None}, "missing"),
        ({"B": np.full((5, 4, 18), 1 / 18)}, "B of shape"),
        ({"pi": np.full((4, 4), 0.25)}, "pi of shape"),
        ({"A": np.full((5, 1, 4, 4), 0.3)}, "rows summing to 1"),
        ({"B": np.full((5, 4, 19), np.nan)}, "finite"),
    ],
)
def test_refuses_mismatched_files(tmp_path, overrides, needle):
    path = _write(tmp_path / "bad.npz", **overrides)
    with pytest.raises(PerceptionInputError, match=needle) as err:
        load_models(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_refuses_corrupt_and_missing_files(tmp_path, models):
    path = save_models(tmp_path / "ok.npz", models)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(PerceptionInputError, match="readable") as err:
        load_models(path)
    assert "\n" not in str(err.value)
    with pytest.raises(PerceptionInputError, match="readable"):
        load_models(tmp_path / "absent.npz")
    (tmp_path / "text.npz").write_text("not a zip")
    with pytest.raises(PerceptionInputError, match="readable"):
        load_models(tmp_path / "text.npz")


def test_cells_per_item_are_stored_and_checked(tmp_path, models):
    from perception.hmm.storage import load_cells_per_item

    path = save_models(tmp_path / "with_sizes.npz", models, cells_per_item=[np.inf, 20, 16, 13])
    assert np.array_equal(load_cells_per_item(path), [np.inf, 20, 16, 13])
    assert load_cells_per_item(save_models(tmp_path / "plain.npz", models)) is None
    with pytest.raises(PerceptionInputError, match="cells_per_item"):
        save_models(tmp_path / "bad.npz", models, cells_per_item=[1, 0, 1, 1])


def test_trained_models_are_cached(tmp_path):
    from sim.flow.catalogue import load_catalogue
    from sim.sensing.stripe_hmms import trained_models

    catalogue = load_catalogue()
    cache = tmp_path / "cache.npz"
    first, sizes = trained_models(catalogue, cache=cache, train_seeds=(0, 1), extra_seeds=())
    assert cache.exists() and np.all(sizes[1:] > 1)
    again, sizes_again = trained_models(catalogue, cache=cache, train_seeds=(5,), extra_seeds=())
    assert np.array_equal(again.B, first.B) and np.array_equal(sizes, sizes_again)
