"""Trained stripe HMMs for an episode: trained once from generated flows, cached as `.npz`.

The episode runner needs the five stripe models and the expected cells per item of each class
(for k-means's k). Both come from labelled generated recordings (`sim.flow.labelled_grids`),
trained as
`sortsim hmm-eval` does; the result is written to `cache` and read back on later calls, so only
the first episode pays the training (about 10 s for the default seeds).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from perception.codes import N_STATES
from perception.errors import PerceptionInputError
from perception.hmm.storage import load_cells_per_item, load_models, save_models
from perception.hmm.stripes import StripeHmms
from perception.hmm.training import TrainConfig, train
from perception.items.from_grid import cells_per_item
from sim.flow.labelled_grids import Recording, record

TRAIN_SEEDS = tuple(range(12))
EXTRA_SEEDS = tuple(range(200, 212))


def item_sizes(recordings: list[Recording], n_states: int = N_STATES) -> np.ndarray:
    """(N,) expected expanded cells per item of each class in labelled recordings."""
    counts = np.zeros(n_states)
    for rec in recordings:
        inside = rec.item_cell[:, 0] < rec.classes.shape[0]
        counts += np.bincount(rec.item_class[inside] - 1, minlength=n_states)
    return cells_per_item([r.classes for r in recordings], counts)


def read_cache(
    path: Path | str, coupled: bool | None = False, n_states: int = N_STATES
) -> tuple[StripeHmms, np.ndarray]:
    """(models, cells per item) of a cache file, refused in one line if it is not a valid one.

    Raises:
        PerceptionInputError: the file is unreadable, of another format or shape, holds
            non-finite numbers or lacks cells_per_item; the message says to delete it.
    """
    try:
        models = load_models(path, states=n_states, coupled=coupled)
        sizes = load_cells_per_item(path, n_states)
        if sizes is None:
            raise PerceptionInputError(f"hmm file {path}", "a file with cells_per_item")
    except PerceptionInputError as exc:
        allowed = f"{exc.allowed} (a cache: delete it to train afresh)"
        raise PerceptionInputError(exc.field, allowed, exc.got, exc.where) from None
    return models, sizes


def trained_models(
    catalogue,
    config: TrainConfig | None = None,
    cache: Path | str | None = None,
    train_seeds=TRAIN_SEEDS,
    extra_seeds=EXTRA_SEEDS,
    mix: dict | None = None,
) -> tuple[StripeHmms, np.ndarray]:
    """(models, cells per item): read from `cache` when it holds valid ones, else trained on
    flows of `catalogue` (with the class `mix` of `FlowConfig`'s keys when given).

    A cache file that is unreadable or of another shape is refused (PerceptionInputError), not
    silently overwritten; delete it to retrain.
    """
    config = TrainConfig() if config is None else config
    n_states = catalogue.materials.n_states
    if cache is not None and Path(cache).exists():
        return read_cache(cache, config.coupled, n_states)
    labelled = [record(s, catalogue, mix) for s in train_seeds]
    extra = [record(s, catalogue, mix).codes for s in extra_seeds]
    classes, codes = [r.classes for r in labelled], [r.codes for r in labelled]
    _, models = train(classes, codes, extra, config, n_states)
    sizes = item_sizes(labelled, n_states)
    if cache is not None:
        save_models(cache, models, sizes)
    return models, sizes
