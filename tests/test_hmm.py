"""The HMM core against hmmlearn's CategoricalHMM (an independent, log-space implementation)."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest
from hmmlearn import hmm

from perception.errors import PerceptionInputError
from perception.hmm.baum_welch import baum_welch
from perception.hmm.model import (
    HmmParams,
    filtered,
    log_likelihood,
    map_decode,
    posteriors,
    predict_next,
    viterbi,
)

TOL = 1e-8


def random_model(rng, n=4, m=19, concentration=1.0) -> HmmParams:
    return HmmParams(
        rng.dirichlet(np.full(n, concentration)),
        rng.dirichlet(np.full(n, concentration), size=n),
        rng.dirichlet(np.full(m, concentration), size=n),
    )


def sample(model: HmmParams, length: int, rng) -> np.ndarray:
    """Codes 1..M drawn from the model (its own sampler, so the test does not trust ours)."""
    state = rng.choice(model.n_states, p=model.pi)
    codes = np.empty(length, dtype=int)
    for t in range(length):
        codes[t] = rng.choice(model.n_symbols, p=model.B[state]) + 1
        state = rng.choice(model.n_states, p=model.A[state])
    return codes


def reference(model: HmmParams, n_iter: int = 1):
    ref = hmm.CategoricalHMM(
        n_components=model.n_states,
        n_features=model.n_symbols,
        init_params="",
        params="ste",
        n_iter=n_iter,
        tol=0.0,
    )
    ref.startprob_ = model.pi.copy()
    ref.transmat_ = model.A.copy()
    ref.emissionprob_ = model.B.copy()
    return ref


def cases(count: int, seed: int):
    rng = np.random.default_rng(seed)
    for i in range(count):
        n, m = (4, 19) if i % 2 == 0 else (int(rng.integers(2, 7)), int(rng.integers(2, 25)))
        model = random_model(rng, n, m, concentration=float(rng.choice([0.3, 1.0, 5.0])))
        lengths = [int(x) for x in rng.integers(1, 120, size=int(rng.integers(1, 4)))]
        yield model, [sample(model, length, rng) for length in lengths]


@pytest.mark.parametrize("chunk", range(4))
def test_matches_hmmlearn_on_200_random_models(chunk):
    """Log-likelihood, posteriors and one Baum-Welch step within 1e-8 (50 models per chunk)."""
    for model, seqs in itertools.islice(cases(200, seed=6), chunk * 50, chunk * 50 + 50):
        ref = reference(model)
        for seq in seqs:
            x = (seq - 1)[:, None]
            assert abs(log_likelihood(model, seq) - ref.score(x)) <= TOL * max(1.0, len(seq))
            assert np.max(np.abs(posteriors(model, seq) - ref.predict_proba(x))) <= TOL
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref.fit(np.concatenate(seqs)[:, None] - 1, [len(s) for s in seqs])
        (ours,), _ = baum_welch([model], [s[None] for s in seqs], max_iter=1)
        assert np.max(np.abs(ours.pi - ref.startprob_)) <= TOL
        assert np.max(np.abs(ours.A - ref.transmat_)) <= TOL
        assert np.max(np.abs(ours.B - ref.emissionprob_)) <= TOL


def test_viterbi_matches_hmmlearn():
    for model, seqs in itertools.islice(cases(40, seed=7), 40):
        ref = reference(model)
        for seq in seqs:
            logprob, path = ref.decode((seq - 1)[:, None], algorithm="viterbi")
            ours = viterbi(model, seq)
            # Ties aside, the paths agree; the path's joint log-probability always does.
            assert np.array_equal(ours, path + 1) or np.isclose(
                _path_logprob(model, seq, ours), logprob, atol=1e-9
            )


def _path_logprob(model, seq, path):
    s = path - 1
    lp = np.log(model.pi[s[0]]) + np.log(model.B[s, seq - 1]).sum()
    return lp + np.log(model.A[s[:-1], s[1:]]).sum()


def test_long_sequence_does_not_underflow():
    rng = np.random.default_rng(1)
    model = random_model(rng)
    seq = sample(model, 20000, rng)
    ll = log_likelihood(model, seq)
    assert np.isfinite(ll) and ll < -1000
    assert np.allclose(posteriors(model, seq).sum(axis=1), 1.0, atol=1e-12)


def test_filtered_last_row_equals_smoothed_last_row_and_prediction_is_stochastic():
    rng = np.random.default_rng(2)
    model = random_model(rng)
    seq = sample(model, 50, rng)
    f, g = filtered(model, seq), posteriors(model, seq)
    assert np.allclose(f[-1], g[-1], atol=1e-12)
    nxt = predict_next(f[-1], model.A)
    assert np.isclose(nxt.sum(), 1.0) and np.all(nxt > 0)
    assert set(map_decode(g)) <= {1, 2, 3, 4}


def test_baum_welch_never_lowers_the_likelihood_and_stops_on_tolerance():
    rng = np.random.default_rng(3)
    truth = random_model(rng, concentration=0.5)
    seqs = [sample(truth, 150, rng)[None] for _ in range(3)]
    start = random_model(rng, concentration=5.0)
    _, history = baum_welch([start], seqs, max_iter=500, tol=1e-2)
    total = history.sum(axis=1)
    assert np.all(np.diff(total) >= -1e-9)
    assert len(total) < 500 and total[-1] - total[-2] < 1e-2 <= total[-2] - total[-3]


@pytest.mark.parametrize(
    ("field", "kwargs"),
    [
        ("pi", {"pi": np.array([0.5, 0.6, 0.0, 0.0])}),
        ("A", {"A": np.full((4, 3), 1 / 3)}),
        ("B", {"B": np.full((3, 19), 1 / 19)}),
        ("A", {"A": np.full((4, 4), np.nan)}),
    ],
)
def test_params_refuse_bad_fields(field, kwargs):
    good = {"pi": np.full(4, 0.25), "A": np.full((4, 4), 0.25), "B": np.full((4, 19), 1 / 19)}
    with pytest.raises(PerceptionInputError) as err:
        HmmParams(**{**good, **kwargs})
    assert err.value.field == field


def test_codes_out_of_range_are_refused():
    model = random_model(np.random.default_rng(4))
    with pytest.raises(PerceptionInputError, match="obs"):
        log_likelihood(model, np.array([1, 20]))
    with pytest.raises(PerceptionInputError, match="obs"):
        posteriors(model, np.array([0, 3]))


def test_prior_pseudo_counts_keep_unseen_codes_possible():
    from perception.hmm.baum_welch import Prior

    rng = np.random.default_rng(5)
    model = random_model(rng)
    seq = np.array([19, 19, 3, 3, 19] * 10)
    (plain,), _ = baum_welch([model], [seq], max_iter=3, tol=0.0)
    prior = Prior(np.full((1, 4), 0.5), np.full((1, 4, 4), 0.5), np.full((1, 4, 19), 0.5))
    (smoothed,), _ = baum_welch([model], [seq], max_iter=3, tol=0.0, prior=prior)
    assert plain.B[:, 0].max() < 1e-12
    assert smoothed.B.min() > 0 and smoothed.A.min() > 0
