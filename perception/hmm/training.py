"""Training of the stripe HMMs: supervised counts (thesis 3.2.2), then Baum-Welch (3.2.3).

Initialisation, per stripe, from labelled grids (rows x 5 stripes of true classes and codes):
- pi: how often each class appears in the stripe over the number of rows (the thesis counts
  appearances of each class per column and divides by the rows);
- A: transitions i -> j between consecutive rows of the stripe over the appearances of i;
- B: appearances of class i with code k over the appearances of i.
Each count gets `smoothing` added first (additive smoothing), so no probability is exactly zero
and Baum-Welch can never lock a transition or a code out. The coupled variant counts A[s, c]
with weight 1/|neighbours| for each neighbour of stripe s in class c at t-1.

Re-estimation then runs Baum-Welch on the codes alone of a mix of sequences (the thesis mixes
real and generated recordings). Unlabelled EM may wander away from the class semantics the
counts gave each state, so the counted model also enters as Dirichlet pseudo-counts of weight
`anchor` per row (0 = the plain Baum-Welch of the thesis). The M-step adds `smoothing` to every
expected count as well, so no probability becomes exactly zero during re-estimation either.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from perception.codes import N_CODES, N_STATES
from perception.errors import PerceptionInputError
from perception.hmm.stripes import StripeHmms, reestimate


@dataclass(frozen=True)
class TrainConfig:
    """How the stripe HMMs are trained.

    Attributes:
        smoothing: Additive pseudo-count on every counted entry (> 0).
        coupled: Transitions per neighbour context (thesis 1.3) or independent stripes.
        max_iter: Baum-Welch iterations at most (0 keeps the counted model).
        tol: Stop once an iteration gains less log-likelihood than this [nats].
        anchor: Pseudo-counts per row pulling re-estimation toward the counted model (>= 0).
    """

    smoothing: float = 0.5
    coupled: bool = False
    max_iter: int = 5
    tol: float = 1e-2
    anchor: float = 0.0

    def __post_init__(self):
        if not (np.isfinite(self.smoothing) and self.smoothing > 0):
            raise PerceptionInputError("smoothing", "a pseudo-count > 0", self.smoothing)
        if int(self.max_iter) != self.max_iter or self.max_iter < 0:
            raise PerceptionInputError("max_iter", "an integer >= 0", self.max_iter)
        if not self.tol >= 0:
            raise PerceptionInputError("tol", "a log-likelihood gain >= 0 [nats]", self.tol)
        if not (np.isfinite(self.anchor) and self.anchor >= 0):
            raise PerceptionInputError("anchor", "a pseudo-count >= 0 per row", self.anchor)


def _grid(name: str, grid, low: int, high: int, stripes: int | None) -> np.ndarray:
    arr = np.asarray(grid)
    shape_ok = arr.ndim == 2 and arr.shape[0] >= 2 and (stripes is None or arr.shape[1] == stripes)
    if not shape_ok or not np.issubdtype(arr.dtype, np.integer):
        raise PerceptionInputError(name, "integer grids of shape (rows >= 2, stripes)", arr.shape)
    if arr.min() < low or arr.max() > high:
        raise PerceptionInputError(name, f"values {low}..{high}", (arr.min(), arr.max()))
    return arr.astype(np.intp)


def neighbour_classes(classes: np.ndarray, n_states: int = N_STATES) -> np.ndarray:
    """(rows, S, N) fraction of each stripe's neighbours in each class (1/|neighbours| each)."""
    rows, s = classes.shape
    onehot = np.eye(n_states)[classes - 1]
    out = np.zeros((rows, s, n_states))
    if s == 1:
        return out + 1.0 / n_states
    out[:, 1:] += onehot[:, :-1]
    out[:, :-1] += onehot[:, 1:]
    out[:, 1:-1] *= 0.5
    return out


def count_models(
    classes_grids,
    codes_grids,
    smoothing: float = 0.5,
    coupled: bool = False,
    n_states: int = N_STATES,
):
    """Supervised StripeHmms from labelled grids (thesis 3.2.2) with additive smoothing.

    Args:
        classes_grids: arrays (rows, S) of true classes 1..n_states, one per recording.
        codes_grids: arrays (rows, S) of observation codes 1..19, aligned with classes_grids.
        smoothing: Pseudo-count added to every counted entry (> 0).
        coupled: Count transitions per neighbour class at t-1 (C = N) or not (C = 1).
        n_states: N, the classes: void and the materials (4: the thesis's three).
    """
    TrainConfig(smoothing=smoothing)
    classes_grids, codes_grids = list(classes_grids), list(codes_grids)
    if not classes_grids or len(classes_grids) != len(codes_grids):
        raise PerceptionInputError("grids", "equal, non-zero numbers of class and code grids")
    s = np.asarray(classes_grids[0]).shape[1] if np.ndim(classes_grids[0]) == 2 else 0
    n_ctx = n_states if coupled else 1
    pi = np.full((s, n_states), smoothing)
    trans = np.full((s, n_ctx, n_states, n_states), smoothing)
    emis = np.full((s, n_states, N_CODES), smoothing)
    stripe = np.arange(s)
    for cls, codes in zip(classes_grids, codes_grids, strict=True):
        cls = _grid("classes", cls, 1, n_states, s)
        codes = _grid("codes", codes, 1, N_CODES, s)
        if codes.shape != cls.shape:
            raise PerceptionInputError("codes", f"a grid of the classes' shape {cls.shape}")
        np.add.at(pi, (stripe[None], cls - 1), 1.0)
        np.add.at(emis, (stripe[None], cls - 1, codes - 1), 1.0)
        prev, nxt = cls[:-1] - 1, cls[1:] - 1
        ctx = neighbour_classes(cls, n_states)[:-1] if coupled else np.ones(prev.shape + (1,))
        for c in range(n_ctx):
            # numpy's stubs take no int among the index arrays of `ufunc.at`.
            index = cast(Any, (stripe[None], c, prev, nxt))
            np.add.at(trans, index, ctx[..., c])
    norm = [m / m.sum(axis=-1, keepdims=True) for m in (pi, trans, emis)]
    return StripeHmms(*norm)


def train(
    classes_grids,
    codes_grids,
    unlabelled_codes=(),
    config: TrainConfig = TrainConfig(),
    n_states: int = N_STATES,
):
    """Counted initialisation on the labelled grids, then Baum-Welch on the codes of all grids.

    Args:
        classes_grids, codes_grids: Labelled recordings (see `count_models`).
        unlabelled_codes: Further (rows, S) code grids used only by re-estimation.
        n_states: Classes (void and the materials).

    Returns:
        (initial, trained) StripeHmms: the counted models and the re-estimated ones.
    """
    initial = count_models(classes_grids, codes_grids, config.smoothing, config.coupled, n_states)
    if config.max_iter == 0:
        return initial, initial
    seqs = [np.asarray(g).T for g in list(codes_grids) + list(unlabelled_codes)]
    # The M-step keeps the additive smoothing, so re-estimation never sets a probability to 0.
    prior = tuple(config.smoothing + config.anchor * m for m in (initial.pi, initial.A, initial.B))
    trained, _ = reestimate(initial, seqs, config.max_iter, config.tol, prior)
    return initial, trained
