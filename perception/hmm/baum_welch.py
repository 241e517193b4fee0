"""Baum-Welch re-estimation (thesis eqs. 2.14-2.18) of K categorical HMMs over many sequences.

The E-step runs the scaled forward/backward of `perception.hmm.model` on a batch of K sequences of
one
length (one per stripe) and sums, per model, the expected counts of the first state, of the
transitions (di-gammas) and of each code per state. Sequences of different lengths are processed
one after another and their counts added, which is the multiple-sequence re-estimation of
Rabiner (1989) section V.B. The M-step divides the counts by their row sums; optional Dirichlet
pseudo-counts (`Prior`) are added first, which keeps every probability above zero and, for the
online re-estimation, anchors the model to its trained values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from perception.errors import PerceptionInputError
from perception.hmm.model import HmmParams, backward, check_codes, emission_probs, forward, stack


@dataclass(frozen=True, eq=False)
class Prior:
    """Dirichlet pseudo-counts added to the expected counts before normalising.

    Attributes:
        pi: (K, N) pseudo-counts of the first state.
        A: (K, N, N) pseudo-counts of the transitions.
        B: (K, N, M) pseudo-counts of the emissions.
    """

    pi: np.ndarray
    A: np.ndarray
    B: np.ndarray


def e_step(pi: np.ndarray, A: np.ndarray, B: np.ndarray, obs: np.ndarray) -> dict:
    """Expected counts of K models on K sequences of codes obs (K, T).

    Returns:
        dict with `start` (K, N), `obs` (K, N, M), `trans` (K, N, N) when A is shared over time,
        `loglik` (K,), and the lattices `alpha` (K, T, N) and `g` (K, T, N), where
        g_t(j) = b_j(o_t) beta_hat_t(j) c_t so that xi_t-1(i, j) = alpha_t-1(i) a_ij g_t(j).
    """
    Bo = emission_probs(B, obs)
    alpha, c = forward(pi, A, Bo)
    beta = backward(A, Bo, c)
    gamma = alpha * beta
    onehot = np.zeros(obs.shape + (B.shape[2],))
    np.put_along_axis(onehot, obs[..., None] - 1, 1.0, axis=2)
    g = Bo * beta * c[..., None]
    stats = {
        "start": gamma[:, 0],
        "obs": np.einsum("ktn,ktm->knm", gamma, onehot),
        "loglik": -np.log(c).sum(axis=1),
        "alpha": alpha,
        "g": g,
    }
    if A.ndim == 3:
        stats["trans"] = A * np.einsum("kti,ktj->kij", alpha[:, :-1], g[:, 1:])
    return stats


def normalise_rows(counts: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Counts divided by their row sums; a row with no count keeps its `fallback` row."""
    totals = counts.sum(axis=-1, keepdims=True)
    safe = np.where(totals > 0.0, totals, 1.0)
    return np.where(totals > 0.0, counts / safe, fallback)


def _batches(sequences, k: int, n_symbols: int):
    out = []
    for seq in sequences:
        arr = check_codes(seq, n_symbols)
        if arr.ndim == 1 and k == 1:
            arr = arr[None]
        if arr.ndim != 2 or arr.shape[0] != k or arr.shape[1] < 1:
            raise PerceptionInputError("sequences", f"arrays of shape ({k}, T >= 1)", arr.shape)
        out.append(arr)
    if not out:
        raise PerceptionInputError("sequences", "at least one sequence", 0)
    return out


def baum_welch(
    models,
    sequences,
    max_iter: int = 20,
    tol: float = 1e-4,
    prior: Prior | None = None,
):
    """Re-estimate K models, model k on row k of every sequence, until converged.

    Args:
        models: K `HmmParams` of one size.
        sequences: arrays of codes 1..M, each (K, T_e) (or (T_e,) when K == 1).
        max_iter: Maximum number of E+M iterations (>= 1).
        tol: Stop once an iteration raises the total log-likelihood by less than this [nats].
        prior: Optional pseudo-counts added to the expected counts.

    Returns:
        (models, history): the re-estimated K models and a (iterations, K) array of each model's
        log-likelihood under the parameters that iteration started from (as hmmlearn reports).
    """
    if int(max_iter) != max_iter or max_iter < 1:
        raise PerceptionInputError("max_iter", "an integer >= 1", max_iter)
    if not tol >= 0.0:
        raise PerceptionInputError("tol", "a log-likelihood gain >= 0 [nats]", tol)
    models = list(models)
    pi, A, B = stack(models)
    batches = _batches(sequences, len(models), B.shape[2])
    history = []
    for _ in range(int(max_iter)):
        start, trans, emis = np.zeros_like(pi), np.zeros_like(A), np.zeros_like(B)
        loglik = np.zeros(len(models))
        for obs in batches:
            stats = e_step(pi, A, B, obs)
            start += stats["start"]
            trans += stats["trans"]
            emis += stats["obs"]
            loglik += stats["loglik"]
        if prior is not None:
            start, trans, emis = start + prior.pi, trans + prior.A, emis + prior.B
        pi, A, B = normalise_rows(start, pi), normalise_rows(trans, A), normalise_rows(emis, B)
        history.append(loglik)
        if len(history) > 1 and history[-1].sum() - history[-2].sum() < tol:
            break
    new = [HmmParams(pi[k], A[k], B[k]) for k in range(len(models))]
    return new, np.array(history)
