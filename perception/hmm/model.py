"""Categorical hidden Markov model: parameters, scaled forward/backward, decoding, prediction.

One model per belt stripe (thesis 1.3, 3.2): N = 4 hidden states (void, paper, plastic,
aluminium; table 3.1) and M = 19 observation codes (table 3.2). States and codes are 1-based at
this module's boundary, as in the thesis; arrays of probabilities are indexed state - 1.

The forward/backward passes follow Stamp, "A Revealing Introduction to Hidden Markov Models":
alpha is normalised at every step by c_t = 1 / sum_i alpha~_t(i) and beta is scaled with the same
c_t, so log P(O | lambda) = -sum_t log c_t and no product underflows. Every function works on a
batch of K sequences of one length (one per stripe, or one per training sequence) with a model
per sequence, so the loop runs over time only and the states and the batch are numpy-vectorised.
Transitions may be shared over time, `(K, N, N)`, or given per step, `(K, T, N, N)`, where
`A[:, t]` moves the chain from row t-1 into row t (the coupled stripes of `hmm_coupling`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from perception.errors import PerceptionInputError

STOCHASTIC_TOL = 1e-6


def check_stochastic(name: str, matrix: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """Return `matrix` as float64 after checking its shape and that its last axis sums to 1.

    Raises:
        PerceptionInputError: naming `name` when the shape, finiteness or sums are wrong.
    """
    arr = np.asarray(matrix, dtype=np.float64)
    if arr.shape != shape:
        raise PerceptionInputError(name, f"shape {shape}", arr.shape)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0.0):
        raise PerceptionInputError(name, "finite probabilities >= 0", "negative or non-finite")
    worst = float(np.max(np.abs(arr.sum(axis=-1) - 1.0))) if arr.size else 0.0
    if worst > STOCHASTIC_TOL:
        raise PerceptionInputError(name, f"rows summing to 1 within {STOCHASTIC_TOL}", worst)
    return arr


@dataclass(frozen=True, eq=False)
class HmmParams:
    """lambda = (pi, A, B) of one categorical HMM, validated eagerly.

    Attributes:
        pi: (N,) initial state distribution.
        A: (N, N) transitions, A[i, j] = P(q_t+1 = j+1 | q_t = i+1).
        B: (N, M) emissions, B[i, k] = P(o_t = k+1 | q_t = i+1).
    """

    pi: np.ndarray
    A: np.ndarray
    B: np.ndarray

    def __post_init__(self):
        pi = np.asarray(self.pi, dtype=np.float64)
        if pi.ndim != 1 or pi.size < 1:
            raise PerceptionInputError("pi", "a 1-D array of N >= 1 probabilities", pi.shape)
        n = pi.size
        b = np.asarray(self.B, dtype=np.float64)
        if b.ndim != 2 or b.shape[0] != n or b.shape[1] < 1:
            raise PerceptionInputError("B", f"shape ({n}, M)", b.shape)
        for name, arr, shape in (("pi", pi, (n,)), ("A", self.A, (n, n)), ("B", b, b.shape)):
            arr = check_stochastic(name, arr, shape).copy()
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)

    @property
    def n_states(self) -> int:
        """N, the number of hidden states."""
        return self.pi.size

    @property
    def n_symbols(self) -> int:
        """M, the number of observation codes."""
        return self.B.shape[1]


def stack(models: list[HmmParams] | tuple[HmmParams, ...]):
    """(pi (K, N), A (K, N, N), B (K, N, M)) of K models of one size, for the batched passes."""
    return (
        np.stack([m.pi for m in models]),
        np.stack([m.A for m in models]),
        np.stack([m.B for m in models]),
    )


def check_codes(obs, n_symbols: int) -> np.ndarray:
    """Observation codes as an int array, refused unless every code is in 1..M."""
    arr = np.asarray(obs)
    if arr.size and (
        not np.issubdtype(arr.dtype, np.integer) or arr.min() < 1 or arr.max() > n_symbols
    ):
        raise PerceptionInputError("obs", f"integer codes 1..{n_symbols}", arr.dtype)
    return arr.astype(np.intp)


def emission_probs(B: np.ndarray, obs: np.ndarray) -> np.ndarray:
    """(K, T, N) b_i(o_t) for B (K, N, M) and 1-based codes obs (K, T)."""
    return np.take_along_axis(B, obs[:, None, :] - 1, axis=2).transpose(0, 2, 1)


def _step_matrix(A: np.ndarray, t: int) -> np.ndarray:
    return A[:, t] if A.ndim == 4 else A


def forward(pi: np.ndarray, A: np.ndarray, Bo: np.ndarray):
    """Scaled alpha-pass (Stamp): alpha_hat (K, T, N) filtered posteriors and c (K, T).

    Each alpha_hat[:, t] is P(q_t | o_1..o_t), and log P(O | lambda) = -sum_t log c_t.
    """
    k, t_len, n = Bo.shape
    alpha = np.empty((k, t_len, n))
    c = np.empty((k, t_len))
    a = pi * Bo[:, 0]
    for t in range(t_len):
        if t:
            a = np.matmul(alpha[:, t - 1, None, :], _step_matrix(A, t))[:, 0] * Bo[:, t]
        total = a.sum(axis=1)
        c[:, t] = 1.0 / total
        alpha[:, t] = a * c[:, t, None]
    return alpha, c


def backward(A: np.ndarray, Bo: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Beta-pass scaled with the alpha-pass's c_t, so that gamma_t = alpha_hat_t * beta_hat_t.

    beta_hat_T = 1 and beta_hat_t(i) = c_t+1 sum_j a_ij b_j(o_t+1) beta_hat_t+1(j); this is
    Stamp's beta with the factor c_t moved one step, which makes gamma need no division.
    """
    k, t_len, n = Bo.shape
    beta = np.empty((k, t_len, n))
    beta[:, -1] = 1.0
    for t in range(t_len - 2, -1, -1):
        g = Bo[:, t + 1] * beta[:, t + 1]
        np.multiply(g, c[:, t + 1, None], out=g)  # g *= c in place: the same product
        beta[:, t] = np.matmul(_step_matrix(A, t + 1), g[:, :, None])[:, :, 0]
    return beta


def log_likelihood(params: HmmParams, obs) -> float:
    """log P(O | lambda) of one sequence of codes 1..M."""
    o = check_codes(obs, params.n_symbols)[None]
    pi, A, B = stack([params])
    _, c = forward(pi, A, emission_probs(B, o))
    return float(-np.log(c).sum())


def posteriors(params: HmmParams, obs) -> np.ndarray:
    """(T, N) smoothed posteriors gamma_t(i) = P(q_t = i+1 | O, lambda)."""
    o = check_codes(obs, params.n_symbols)[None]
    pi, A, B = stack([params])
    Bo = emission_probs(B, o)
    alpha, c = forward(pi, A, Bo)
    return (alpha * backward(A, Bo, c))[0]


def filtered(params: HmmParams, obs) -> np.ndarray:
    """(T, N) filtered posteriors P(q_t = i+1 | o_1..o_t): what an online decoder knows."""
    o = check_codes(obs, params.n_symbols)[None]
    pi, A, B = stack([params])
    return forward(pi, A, emission_probs(B, o))[0][0]


def map_decode(gamma: np.ndarray) -> np.ndarray:
    """States 1..N maximising each row of posteriors (thesis annex: argmax of gamma)."""
    return np.argmax(gamma, axis=-1) + 1


def viterbi(params: HmmParams, obs) -> np.ndarray:
    """(T,) most likely state path 1..N (log-space Viterbi)."""
    o = check_codes(obs, params.n_symbols)
    with np.errstate(divide="ignore"):
        log_a, log_b, log_pi = np.log(params.A), np.log(params.B), np.log(params.pi)
    delta = log_pi + log_b[:, o[0] - 1]
    back = np.empty((o.size, params.n_states), dtype=np.intp)
    for t in range(1, o.size):
        scores = delta[:, None] + log_a
        back[t] = np.argmax(scores, axis=0)
        delta = scores[back[t], np.arange(params.n_states)] + log_b[:, o[t] - 1]
    path = np.empty(o.size, dtype=np.intp)
    path[-1] = np.argmax(delta)
    for t in range(o.size - 1, 0, -1):
        path[t - 1] = back[t, path[t]]
    return path + 1


def predict_next(alpha_last: np.ndarray, A: np.ndarray) -> np.ndarray:
    """P(q_t+1 | o_1..o_t) = alpha_hat_t A: the next row's class distribution before it is seen.

    Args:
        alpha_last: (..., N) filtered posteriors of the last observed row.
        A: (..., N, N) transition into the next row.
    """
    return np.matmul(alpha_last[..., None, :], A)[..., 0, :]
