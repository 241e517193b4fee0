"""Online operation of the stripe HMMs: one grid row per observation period (thesis 1.3).

Each `step` takes the new row of codes, predicts the row's classes before looking at it
(P(q_t | o_1..t-1)), filters it (P(q_t | o_1..t)) and decodes it (argmax of the filtered
posterior). Every `reestimate_every` rows the models are re-estimated by Baum-Welch on the last
`window` rows only (the thesis re-estimates every period "based on the previous throws, which are
now known"), with the trained models as Dirichlet pseudo-counts of weight `anchor` per row so that
a short window refines the models without forgetting them. Rows live in a fixed ring buffer, so
a step costs the same at row 10 and at row 10 000.

Use in an episode (models and cells per item from `sim.sensing.stripe_hmms.trained_models`):

    online = OnlineStripeHmms(models)
    estimate = online.step(row_codes)          # every period: (5,) codes -> RowEstimate
    ...                                        # every 20 rows: items of the last 20 rows
    items_kmeans(classes_20x5, GridGeometry(v * T), cells_per_item, filtered_20x5x4, first_row=k0)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from perception.errors import PerceptionInputError
from perception.hmm.model import backward, check_codes, emission_probs
from perception.hmm.stripes import (
    StripeHmms,
    context_weights,
    forward_stripes,
    mixed_transitions,
    reestimate,
)


@dataclass(frozen=True)
class OnlineConfig:
    """Options of the online filter.

    Attributes:
        window: Rows kept for re-estimation and smoothing (>= 2).
        reestimate_every: Rows between re-estimations (>= 1; 0 never re-estimates).
        iterations: Baum-Welch iterations per re-estimation (>= 1).
        anchor: Pseudo-counts per row pulling toward the trained models (> 0).
    """

    window: int = 40
    reestimate_every: int = 1
    iterations: int = 1
    anchor: float = 200.0

    def __post_init__(self):
        if int(self.window) != self.window or self.window < 2:
            raise PerceptionInputError("window", "an integer number of rows >= 2", self.window)
        if int(self.reestimate_every) != self.reestimate_every or self.reestimate_every < 0:
            raise PerceptionInputError("reestimate_every", "an integer >= 0", self.reestimate_every)
        if int(self.iterations) != self.iterations or self.iterations < 1:
            raise PerceptionInputError("iterations", "an integer >= 1", self.iterations)
        if not (np.isfinite(self.anchor) and self.anchor > 0):
            raise PerceptionInputError("anchor", "a pseudo-count > 0 per row", self.anchor)


@dataclass(frozen=True)
class RowEstimate:
    """What the filter knows about one row.

    Attributes:
        row: Index of the row since the start (0-based).
        predicted: (S, N) class distribution of the row before its codes were seen.
        filtered: (S, N) class distribution after its codes.
        classes: (S,) decoded classes 1..N (argmax of `filtered`).
    """

    row: int
    predicted: np.ndarray
    filtered: np.ndarray
    classes: np.ndarray


class OnlineStripeHmms:
    """Filters rows of codes as they arrive and re-estimates on a bounded window."""

    def __init__(self, models: StripeHmms, config: OnlineConfig = OnlineConfig()):
        self.base = models
        self.models = models
        self.config = config
        self._prior = tuple(config.anchor * m for m in (models.pi, models.A, models.B))
        s, n = models.pi.shape
        self._codes = np.zeros((config.window, s), dtype=np.intp)
        self._predicted = np.zeros((config.window, s, n))
        self._alpha: np.ndarray | None = None
        self.rows = 0

    def next_prediction(self) -> np.ndarray:
        """(S, N) class distribution of the row that has not arrived yet."""
        if self._alpha is None:
            return self.models.pi.copy()
        steps = mixed_transitions(self.models, context_weights(self.models, self._alpha))
        return np.matmul(self._alpha[:, None, :], steps)[:, 0]

    def step(self, codes_row) -> RowEstimate:
        """Take the next row of codes (S,), 1..M; return its prediction, filter and decoding."""
        s, n_symbols = self.models.pi.shape[0], self.models.B.shape[2]
        codes = check_codes(codes_row, n_symbols)
        if codes.shape != (s,):
            raise PerceptionInputError("codes_row", f"{s} codes, one per stripe", codes.shape)
        predicted = self.next_prediction()
        a = predicted * self.models.B[np.arange(s), :, codes - 1]
        self._alpha = a / a.sum(axis=1, keepdims=True)
        slot = self.rows % self.config.window
        self._codes[slot], self._predicted[slot] = codes, predicted
        estimate = RowEstimate(self.rows, predicted, self._alpha.copy(), np.argmax(a, axis=1) + 1)
        self.rows += 1
        every = self.config.reestimate_every
        if every and self.rows >= self.config.window and self.rows % every == 0:
            self.reestimate()
        return estimate

    def window(self) -> tuple[np.ndarray, np.ndarray]:
        """(codes (W, S), predicted distribution of the window's first row (S, N)), oldest first."""
        w = min(self.rows, self.config.window)
        idx = (np.arange(self.rows - w, self.rows)) % self.config.window
        return self._codes[idx], self._predicted[idx[0]] if w else self.models.pi

    def _window_models(self) -> StripeHmms:
        _, start = self.window()
        start = start / start.sum(axis=1, keepdims=True)
        return self.models.with_start(start)

    def reestimate(self) -> None:
        """Baum-Welch on the last `window` rows, anchored to the trained models."""
        codes, _ = self.window()
        if codes.shape[0] < 2:
            return
        fitted, _ = reestimate(
            self._window_models(), [codes.T], self.config.iterations, 0.0, self._prior
        )
        self.models = fitted.with_start(self.models.pi)

    def smoothed_window(self, last: int | None = None) -> np.ndarray:
        """(W, S, N) smoothed posteriors of the rows in the window (fixed-lag smoothing), or
        of its `last` newest rows only (the backward pass then stops there: the same values).
        """
        codes, _ = self.window()
        models = self._window_models()
        alpha, c, steps, _ = forward_stripes(models, codes.T)
        rows = alpha.shape[1] if last is None else min(int(last), alpha.shape[1])
        start = alpha.shape[1] - rows
        # beta of row t needs only the rows after t: the newest rows' pass is the whole one's.
        bo = emission_probs(models.B, codes.T)[:, start:]
        beta = backward(steps[:, start:], bo, c[:, start:])
        return (alpha[:, start:] * beta).transpose(1, 0, 2)
