"""The mix as shares (`[flow] mix`, `mix_types`): the stripes' Markov chains matched to it
(`sim.flow.mix`), the shares the flows then carry, and the mean item mass a feed in kg/h
counts with."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from sim import config as episode_config
from sim.errors import InvalidInput
from sim.flow import mix as flow_mix
from sim.flow.config import DEFAULT_TRANSITIONS, FlowConfig
from sim.flow.generator import arrivals, generate_flow

PLANT_MIX = {"paper": 0.40, "plastic": 0.35, "aluminium": 0.25}
"""The plant engineer's feed of issue 46: 40 % fibre, 35 % PET and HDPE, 25 % cans."""


def _config(**flow) -> episode_config.EpisodeConfig:
    return episode_config.from_dict({"perception": "truth", "flow": flow})


def _shares(config: episode_config.EpisodeConfig, items: int, seed: int) -> np.ndarray:
    """The materials' shares of the config's flow of `items` items (its classes drawn as the
    generator draws them), at 6 items per metre of belt."""
    duration = items / (6.0 * config.belt_speed_mps)
    flow = FlowConfig(n_items=items, duration_s=duration, seed=seed, **config.mix_kwargs)
    _, _, classes = arrivals(flow, np.random.default_rng(seed))
    return np.bincount(classes, minlength=config.materials.count) / items


def test_the_matched_table_has_the_mix_as_its_stationary_shares_and_keeps_the_odds_ratios():
    config = _config(mix=PLANT_MIX)
    kwargs = config.mix_kwargs
    p, q = np.array(DEFAULT_TRANSITIONS), np.array(kwargs["transitions"])
    target = np.array(list(PLANT_MIX.values()))
    np.testing.assert_allclose(q.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(target @ q, target, atol=1e-12)  # stationary: the mix
    np.testing.assert_allclose(flow_mix.stationary_shares(q), target, atol=1e-12)
    assert kwargs["class_priors"] == tuple(target)  # the chain starts stationary
    # Rows and columns scaled: every odds ratio of the table kept (the clumping).
    for i, j, k, m in itertools.product(range(3), repeat=4):
        ratio = p[i, j] * p[k, m] / (p[i, m] * p[k, j])
        assert q[i, j] * q[k, m] / (q[i, m] * q[k, j]) == pytest.approx(ratio, rel=1e-9)
    # Each class still follows itself more often than its share (clumps), paper the more so
    # now that it is the commonest.
    assert np.all(np.diag(q) > target)
    assert q[0, 0] > p[0, 0] and q[2, 2] < p[2, 2]


def test_a_40_35_25_mix_gives_those_shares_over_600_items_and_long_flows():
    """Every flow of a mix carries it within 2 points (its chains drawn again until they do;
    alone they stray by 2.2-2.8 points over 600 items, `python -m sim.evaluation.mix_shares
    --mix 0.40 0.35 0.25`), and keeps its clumps: a stripe's item follows one of its own class
    about as often as the matched table says; a flow of 100000 items within 1 point at the
    first draw; the default mix is not the plant's."""
    target = np.array(list(PLANT_MIX.values()))
    config = _config(mix=PLANT_MIX)
    short = np.array([_shares(config, 600, seed) for seed in range(100, 130)])
    assert np.abs(short - target).max() < 0.02  # every flow, not only their mean
    long = _shares(config, 100_000, 0)
    assert np.abs(long - target).max() <= 0.01
    default = _shares(_config(), 600 * 20, 0)
    assert abs(default[0] - 0.40) > 0.05  # the default flow is not the plant's mix
    # The clumps kept: same-class successions within a stripe as the chain gives them.
    q = np.array(config.mix_kwargs["transitions"])
    expected = float(target @ np.diag(q))
    same = []
    for seed in range(100, 130):
        flow = FlowConfig(n_items=600, duration_s=600 / (6 * 0.185), seed=seed, **config.mix_kwargs)
        _, stripes, classes = arrivals(flow, np.random.default_rng(seed))
        for k in range(5):
            run = classes[stripes == k]
            same.extend((run[1:] == run[:-1]).tolist())
    assert np.mean(same) == pytest.approx(expected, abs=0.02)


def test_a_flow_without_a_mix_is_drawn_as_before():
    """No mix: the chains' first draw stands (the default flow's classes unchanged)."""
    config = _config()
    assert "held_shares" not in config.mix_kwargs
    flow = FlowConfig(n_items=600, duration_s=600 / (6 * 0.185), seed=3, **config.mix_kwargs)
    rng = np.random.default_rng(3)
    _, stripes, classes = arrivals(flow, rng)
    again = np.random.default_rng(3)
    again.random(600), again.choice(5, size=600, p=np.asarray(flow.stripe_priors))
    from sim.flow.generator import _draw_classes

    np.testing.assert_array_equal(classes, _draw_classes(flow, stripes, again.random(600)))


def test_the_default_flow_carries_its_stationary_shares_the_settings_reference_gives():
    """docs/settings.md writes the default mix as the default transitions' stationary shares
    (28.0 / 36.6 / 35.4 %); long flows carry them within 1 point."""
    config = episode_config.EpisodeConfig()
    shares = np.array(config.material_shares)
    np.testing.assert_allclose(shares, [0.2802, 0.3662, 0.3537], atol=1e-4)
    long = _shares(config, 100_000, 1)
    assert np.abs(long - shares).max() <= 0.01


def test_the_generator_draws_the_classes_arrivals_draws():
    config = episode_config.load(None, seed=7, items=200)
    flow = generate_flow(config.flow_config(), config.item_catalogue)
    _, _, classes = arrivals(config.flow_config(), np.random.default_rng(7))
    ids = np.asarray(config.materials.ids)
    assert np.array_equal(np.sort(flow.class_id), np.sort(ids[classes]))


def test_a_mix_by_item_type_gives_the_types_and_the_materials_their_shares():
    mix_types = {"cardboard_flat": 0.2, "paper_sheet_a4": 0.2, "pet_bottle_0l5": 0.25}
    mix_types |= {"hdpe_bottle_1l": 0.1, "can_330_lying": 0.25}
    config = _config(mix_types=mix_types)
    catalogue = config.item_catalogue
    np.testing.assert_allclose(config.material_shares, [0.40, 0.35, 0.25], atol=1e-12)
    flow = generate_flow(
        FlowConfig(n_items=3000, duration_s=3000 / (6 * 0.185), **config.mix_kwargs), catalogue
    )
    names = [catalogue.types[int(k)].name for k in flow.type_index]
    assert set(names) == set(mix_types)  # the types not named are not drawn
    for name, share in mix_types.items():
        assert names.count(name) / len(names) == pytest.approx(share, abs=0.03), name


def test_the_mean_item_mass_follows_the_mix():
    catalogue = episode_config.EpisodeConfig().item_catalogue
    by_type = {t.name: t.mass for t in catalogue.types}
    paper_only = _config(mix={"paper": 1.0, "plastic": 0.0, "aluminium": 0.0})
    weights = {"paper_sheet_a4": 0.15, "paper_folded_a6": 0.25, "paper_scrap": 0.15}
    weights |= {"cardboard_flat": 0.2, "carton_box_small": 0.25}
    expected = sum(w * by_type[n] for n, w in weights.items()) / sum(weights.values())
    assert paper_only.mean_item_mass_kg == pytest.approx(expected, rel=1e-12)
    cans = _config(mix_types={"can_330_lying": 1.0})
    assert cans.mean_item_mass_kg == pytest.approx(by_type["can_330_lying"], rel=1e-12)


@pytest.mark.parametrize(
    ("flow", "field", "words"),
    [
        ({"mix": {"paper": 0.4, "plastic": 0.35}}, "flow.mix", "summing to 1"),
        ({"mix": {"paper": 0.4, "plastic": 0.6, "glass": 0.0}}, "flow.mix", "one share per"),
        ({"mix": [0.4, 0.35, 0.25]}, "flow.mix", "a table of shares"),
        ({"mix": {"paper": 1.2, "plastic": -0.2, "aluminium": 0.0}}, "flow.mix", "[0, 1]"),
        ({"mix": PLANT_MIX, "class_priors": [0.3, 0.3, 0.4]}, "flow.class_priors", "unset"),
        ({"mix": PLANT_MIX, "mix_types": {"paper_scrap": 1.0}}, "flow.mix_types", "unset"),
        ({"mix_types": {"can_330_lying_crushed": 1.0}}, "flow.mix_types.can", "base item"),
        (
            {
                "mix": {"paper": 0.5, "plastic": 0.5, "aluminium": 0.0},
                "transitions": [[0, 0, 1], [0, 0, 1], [1, 0, 0]],
            },
            "flow.mix",
            "the transitions can reach",
        ),
    ],  # fmt: skip
)
def test_a_bad_mix_is_refused_in_one_line_naming_the_key_and_file(flow, field, words):
    with pytest.raises(InvalidInput) as refused:
        episode_config.from_dict({"flow": flow}, "plant.toml")
    message = str(refused.value)
    assert refused.value.field.startswith(field) and words in message, message
    assert refused.value.where == "plant.toml" and "\n" not in message


def test_a_share_of_zero_leaves_the_material_out():
    config = _config(mix={"paper": 0.6, "plastic": 0.4, "aluminium": 0.0})
    assert _shares(config, 2000, 0)[2] == 0.0
    q = np.array(config.mix_kwargs["transitions"])
    np.testing.assert_allclose(q[:, 2], 0.0)
    np.testing.assert_allclose(q.sum(axis=1), 1.0, atol=1e-12)
