"""Supervised counts (thesis 3.2.2), stripe re-estimation and neighbour coupling."""

from __future__ import annotations

import numpy as np
import pytest

from perception.errors import PerceptionInputError
from perception.hmm.baum_welch import baum_welch
from perception.hmm.model import HmmParams
from perception.hmm.stripes import StripeHmms, infer, reestimate
from perception.hmm.training import TrainConfig, count_models, neighbour_classes, train


def coupled_truth(rng, stripes=5):
    """A generating model whose transitions depend strongly on a neighbour's class at t-1."""
    trans = np.empty((stripes, 4, 4, 4))
    for c in range(4):
        trans[:, c] = rng.dirichlet(np.full(4, 0.5), size=(stripes, 4)) * 0.3
        trans[:, c, :, c] += 0.7  # follow the neighbour's class
    emis = rng.dirichlet(np.full(19, 0.3), size=(stripes, 4))
    return trans, emis


def sample_grid(rng, trans, emis, rows):
    stripes = trans.shape[0]
    cls = np.empty((rows, stripes), dtype=int)
    cls[0] = rng.integers(0, 4, size=stripes)
    for t in range(1, rows):
        for s in range(stripes):
            nb = [n for n in (s - 1, s + 1) if 0 <= n < stripes]
            ctx = cls[t - 1, rng.choice(nb)]
            cls[t, s] = rng.choice(4, p=trans[s, ctx, cls[t - 1, s]])
    codes = np.array([[rng.choice(19, p=emis[s, c]) for s, c in enumerate(row)] for row in cls])
    return cls + 1, codes + 1


def test_counts_follow_the_thesis_on_a_hand_grid():
    cls = np.array([[1], [1], [2], [2], [1]])
    codes = np.array([[19], [19], [14], [8], [19]])
    m = count_models([cls], [codes], smoothing=1e-9)
    assert np.allclose(m.pi[0], [3 / 5, 2 / 5, 0, 0], atol=1e-8)
    assert np.allclose(m.A[0, 0, 0], [1 / 2, 1 / 2, 0, 0], atol=1e-8)
    assert np.allclose(m.A[0, 0, 1], [1 / 2, 1 / 2, 0, 0], atol=1e-8)
    assert np.isclose(m.B[0, 1, 13], 0.5) and np.isclose(m.B[0, 0, 18], 1.0)
    smooth = count_models([cls], [codes], smoothing=0.5)
    assert smooth.A.min() > 0 and smooth.B.min() > 0 and smooth.pi.min() > 0


def test_counts_recover_the_generating_model():
    rng = np.random.default_rng(0)
    trans, emis = coupled_truth(rng)
    grids = [sample_grid(rng, trans, emis, 400) for _ in range(6)]
    m = count_models([g[0] for g in grids], [g[1] for g in grids], coupled=True)
    assert np.max(np.abs(m.B - emis)) < 0.08
    # Counting an interior stripe's move under both neighbours (1/2 each) blurs the contexts a
    # little: these are EM's first responsibilities, not the mixture's maximum likelihood.
    assert np.mean(np.abs(m.A - trans)) < 0.08


def test_independent_stripe_reestimation_equals_single_hmm_baum_welch():
    rng = np.random.default_rng(1)
    models = [
        HmmParams(
            rng.dirichlet(np.ones(4)), rng.dirichlet(np.ones(4), 4), rng.dirichlet(np.ones(19), 4)
        )
        for _ in range(5)
    ]
    stripes = StripeHmms(
        np.stack([m.pi for m in models]),
        np.stack([m.A for m in models])[:, None],
        np.stack([m.B for m in models]),
    )
    seqs = [rng.integers(1, 20, size=(5, n)) for n in (30, 55)]
    ours, hist = reestimate(stripes, seqs, max_iter=3, tol=0.0)
    ref, ref_hist = baum_welch(models, seqs, max_iter=3, tol=0.0)
    assert np.allclose(hist, ref_hist, atol=1e-9)
    for s in range(5):
        assert np.allclose(ours.A[s, 0], ref[s].A, atol=1e-12)
        assert np.allclose(ours.B[s], ref[s].B, atol=1e-12)
        assert np.allclose(ours.pi[s], ref[s].pi, atol=1e-12)


def test_coupling_helps_when_the_flow_is_coupled():
    rng = np.random.default_rng(2)
    trans, emis = coupled_truth(rng)
    train_grids = [sample_grid(rng, trans, emis, 300) for _ in range(4)]
    test_grids = [sample_grid(rng, trans, emis, 300) for _ in range(2)]
    cls_tr, codes_tr = [g[0] for g in train_grids], [g[1] for g in train_grids]
    scores = {}
    for coupled in (False, True):
        model = count_models(cls_tr, codes_tr, coupled=coupled)
        hits = []
        for cls, codes in test_grids:
            pred = infer(model, codes.T)["predicted"]
            hits.append(np.argmax(pred, axis=2).T + 1 == cls)
        scores[coupled] = np.mean(hits)
    assert scores[True] > scores[False] + 0.05


def test_training_reestimates_and_anchor_keeps_semantics():
    rng = np.random.default_rng(3)
    trans, emis = coupled_truth(rng)
    grids = [sample_grid(rng, trans, emis, 200) for _ in range(3)]
    unlabelled = [sample_grid(rng, trans, emis, 200)[1] for _ in range(2)]
    cfg = TrainConfig(max_iter=3, tol=0.0, anchor=50.0)
    initial, trained = train([g[0] for g in grids], [g[1] for g in grids], unlabelled, cfg)
    assert not np.allclose(initial.B, trained.B)
    cls, codes = sample_grid(rng, trans, emis, 300)
    acc = [
        np.mean(np.argmax(infer(m, codes.T)["smoothed"], axis=2).T + 1 == cls)
        for m in (initial, trained)
    ]
    assert acc[1] > acc[0] - 0.02


def test_neighbour_classes_edges_have_one_neighbour():
    cls = np.array([[1, 2, 3, 4, 1]])
    nb = neighbour_classes(cls)[0]
    assert np.allclose(nb[0], [0, 1, 0, 0]) and np.allclose(nb[4], [0, 0, 0, 1])
    assert np.allclose(nb[2], [0, 0.5, 0, 0.5])


@pytest.mark.parametrize(
    ("field", "kwargs"),
    [("smoothing", {"smoothing": 0.0}), ("max_iter", {"max_iter": -1}), ("anchor", {"anchor": -1})],
)
def test_config_refuses(field, kwargs):
    with pytest.raises(PerceptionInputError) as err:
        TrainConfig(**kwargs)
    assert err.value.field == field


def test_counts_refuse_bad_grids():
    with pytest.raises(PerceptionInputError, match="classes"):
        count_models([np.array([[5, 1], [1, 1]])], [np.array([[19, 19], [19, 19]])])
    with pytest.raises(PerceptionInputError, match="codes"):
        count_models([np.array([[1, 1], [1, 1]])], [np.array([[0, 19], [19, 19]])])
