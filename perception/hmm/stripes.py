"""The belt's S = 5 stripe HMMs together, optionally coupled through their neighbours at t-1.

Coupling (thesis 1.3: each stripe's re-estimation uses the neighbouring stripes' states at t-1).
Stripe s holds C transition matrices A[s, c], one per *context* c. The context of the move from
row t-1 to row t is the class of a neighbouring stripe at t-1, which the online filter does not
know; it knows the neighbours' filtered posteriors alpha_hat_n(t-1). So the context is treated as
a latent variable drawn per row with probabilities

    w_s,c(t) = mean over the neighbours n of s of P(q_n,t-1 = c | o_n,1..t-1),

and the transition the stripe uses is the mixture A_s(t) = sum_c w_s,c(t) A[s, c], which is row
stochastic for any w. With C = 1 (w = 1) the stripes are the thesis's five independent HMMs.
Given w the stripe's chain is an ordinary time-varying HMM, so the scaled forward/backward of
`perception.hmm.model` apply unchanged. Re-estimation is exact EM over the latent context: the
expected
count of (context c, i -> j) at row t is xi_t(i, j) w_c(t) A[c, i, j] / A(t)[i, j], and because
xi_t(i, j) = alpha_t-1(i) A(t)[i, j] g_t(j), the division cancels and the counts are one einsum.
The weights w are recomputed from the current models at every E-step (the neighbours' filters are
exogenous inputs to each stripe, as in the online filter, so an iteration is EM for fixed w).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from perception.errors import PerceptionInputError
from perception.hmm.baum_welch import normalise_rows
from perception.hmm.model import backward, check_codes, check_stochastic, emission_probs

N_STRIPES = 5


@dataclass(frozen=True, eq=False)
class StripeHmms:
    """Parameters of S stripe HMMs; C = 1 independent, C = N coupled through neighbours.

    Attributes:
        pi: (S, N) initial state distributions.
        A: (S, C, N, N) transitions per stripe and neighbour context.
        B: (S, N, M) emissions.
    """

    pi: np.ndarray
    A: np.ndarray
    B: np.ndarray

    def __post_init__(self):
        pi = np.asarray(self.pi, dtype=np.float64)
        a = np.asarray(self.A, dtype=np.float64)
        b = np.asarray(self.B, dtype=np.float64)
        if pi.ndim != 2 or pi.shape[0] < 1 or pi.shape[1] < 1:
            raise PerceptionInputError("pi", "shape (S, N)", pi.shape)
        s, n = pi.shape
        if a.ndim != 4 or a.shape[1] not in (1, n) or a.shape[0] != s:
            raise PerceptionInputError("A", f"shape ({s}, 1 or {n}, {n}, {n})", a.shape)
        if b.ndim != 3 or b.shape[:2] != (s, n) or b.shape[2] < 1:
            raise PerceptionInputError("B", f"shape ({s}, {n}, M)", b.shape)
        for name, arr in (("pi", pi), ("A", a), ("B", b)):
            arr = check_stochastic(name, arr, arr.shape).copy()
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)

    def with_start(self, pi: np.ndarray) -> StripeHmms:
        """These models with the start distributions `pi` (S, N), checked as the constructor
        checks them; the transitions and emissions, checked and read-only, are shared rather
        than checked and copied again (the online filter does this twice a period)."""
        pi = check_stochastic("pi", pi, self.pi.shape).copy()
        pi.flags.writeable = False
        out = object.__new__(StripeHmms)
        for name, arr in (("pi", pi), ("A", self.A), ("B", self.B)):
            object.__setattr__(out, name, arr)
        return out

    @property
    def coupled(self) -> bool:
        """True when the transitions depend on the neighbours' states at t-1."""
        return self.A.shape[1] > 1

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """(S stripes, C contexts, N states, M codes)."""
        return (self.pi.shape[0], self.A.shape[1], self.pi.shape[1], self.B.shape[2])


def context_weights(models: StripeHmms, alpha_prev: np.ndarray) -> np.ndarray:
    """(S, C) context probabilities of each stripe from all stripes' posteriors (S, N) at t-1."""
    s, n = alpha_prev.shape
    if not models.coupled:
        return np.ones((s, 1))
    if s == 1:
        return np.full((1, n), 1.0 / n)
    w = np.empty_like(alpha_prev)
    w[1:-1] = 0.5 * (alpha_prev[:-2] + alpha_prev[2:])
    w[0], w[-1] = alpha_prev[1], alpha_prev[-2]
    return w


def mixed_transitions(models: StripeHmms, weights: np.ndarray) -> np.ndarray:
    """(S, N, N) sum_c w_s,c A[s, c]."""
    return np.einsum("sc,scij->sij", weights, models.A)


def forward_stripes(models: StripeHmms, obs: np.ndarray):
    """Joint scaled forward pass of the S stripes on codes obs (S, T).

    Returns:
        alpha (S, T, N) filtered posteriors, c (S, T) scales, A_steps (S, T, N, N) the transition
        each stripe used into row t (A_steps[:, 0] unused), w (S, T, C) the context weights.
    """
    s, t_len = obs.shape
    n, n_ctx = models.pi.shape[1], models.A.shape[1]
    Bo = emission_probs(models.B, obs)
    alpha, c = np.empty((s, t_len, n)), np.empty((s, t_len))
    steps, w = np.empty((s, t_len, n, n)), np.zeros((s, t_len, n_ctx))
    steps[:, 0] = models.A[:, 0]
    coupled = models.coupled
    if not coupled and t_len > 1:
        # Independent stripes: every row's context weight is 1 and its transition the same,
        # mixed once (the values the loop would mix at every row).
        w[:, 1:] = context_weights(models, models.pi)[:, None]
        steps[:, 1:] = mixed_transitions(models, w[:, 1])[:, None]
    a = models.pi * Bo[:, 0]
    for t in range(t_len):
        if t:
            if coupled:
                w[:, t] = context_weights(models, alpha[:, t - 1])
                steps[:, t] = mixed_transitions(models, w[:, t])
            a = np.matmul(alpha[:, t - 1, None, :], steps[:, t])[:, 0] * Bo[:, t]
        # c = 1 / a.sum(axis=1) and alpha = a * c, written in place (the same ufuncs).
        np.divide(1.0, np.add.reduce(a, axis=1), out=c[:, t])
        np.multiply(a, c[:, t, None], out=alpha[:, t])
    return alpha, c, steps, w


def _codes(models: StripeHmms, obs) -> np.ndarray:
    arr = check_codes(obs, models.B.shape[2])
    if arr.ndim != 2 or arr.shape[0] != models.pi.shape[0] or arr.shape[1] < 1:
        raise PerceptionInputError("obs", f"codes of shape ({models.pi.shape[0]}, T)", arr.shape)
    return arr


def infer(models: StripeHmms, obs) -> dict:
    """Filtered, smoothed and one-step-predicted class distributions of every row.

    Args:
        obs: (S, T) codes 1..M, stripe-major (a grid of rows x stripes transposed).

    Returns:
        dict of (S, T, N) arrays `filtered` P(q_t | o_1..t), `smoothed` P(q_t | o_1..T),
        `predicted` P(q_t | o_1..t-1) (row 0: pi), and `loglik` (S,).
    """
    obs = _codes(models, obs)
    alpha, c, steps, _ = forward_stripes(models, obs)
    beta = backward(steps, emission_probs(models.B, obs), c)
    predicted = np.empty_like(alpha)
    predicted[:, 0] = models.pi
    predicted[:, 1:] = np.matmul(alpha[:, :-1, None, :], steps[:, 1:])[:, :, 0]
    return {
        "filtered": alpha,
        "smoothed": alpha * beta,
        "predicted": predicted,
        "loglik": -np.log(c).sum(axis=1),
    }


def expected_counts(models: StripeHmms, obs: np.ndarray) -> tuple[np.ndarray, ...]:
    """E-step on one (S, T) sequence.

    Returns:
        Expected counts of the start (S, N), transitions (S, C, N, N), codes (S, N, M), and the
        log-likelihoods (S,).
    """
    # The joint forward pass's alpha and c are `forward`'s of its steps (the same operations).
    alpha, c, steps, w = forward_stripes(models, obs)
    Bo = emission_probs(models.B, obs)
    beta = backward(steps, Bo, c)
    gamma = alpha * beta
    g = Bo * beta * c[..., None]
    trans = models.A * np.einsum("stc,sti,stj->scij", w[:, 1:], alpha[:, :-1], g[:, 1:])
    onehot = np.zeros(obs.shape + (models.B.shape[2],))
    np.put_along_axis(onehot, obs[..., None] - 1, 1.0, axis=2)
    emis = np.einsum("stn,stm->snm", gamma, onehot)
    return gamma[:, 0], trans, emis, -np.log(c).sum(axis=1)


def reestimate(models: StripeHmms, sequences, max_iter: int = 10, tol: float = 1e-3, prior=None):
    """Baum-Welch on (S, T_e) sequences of all stripes; `prior` is a StripeHmms-shaped tuple
    (pi, A, B) of pseudo-counts or None. Returns (models, (iterations, S) log-likelihoods)."""
    if int(max_iter) != max_iter or max_iter < 1:
        raise PerceptionInputError("max_iter", "an integer >= 1", max_iter)
    if not tol >= 0.0:
        raise PerceptionInputError("tol", "a log-likelihood gain >= 0 [nats]", tol)
    seqs = [_codes(models, seq) for seq in sequences]
    if not seqs:
        raise PerceptionInputError("sequences", "at least one (S, T) sequence", 0)
    history = []
    for _ in range(int(max_iter)):
        totals = [np.zeros_like(models.pi), np.zeros_like(models.A), np.zeros_like(models.B)]
        loglik = np.zeros(models.pi.shape[0])
        for obs in seqs:
            *counts, ll = expected_counts(models, obs)
            totals = [tot + cnt for tot, cnt in zip(totals, counts, strict=True)]
            loglik += ll
        if prior is not None:
            totals = [tot + p for tot, p in zip(totals, prior, strict=True)]
        models = StripeHmms(
            normalise_rows(totals[0], models.pi),
            normalise_rows(totals[1], models.A),
            normalise_rows(totals[2], models.B),
        )
        history.append(loglik)
        if len(history) > 1 and history[-1].sum() - history[-2].sum() < tol:
            break
    return models, np.array(history)
