"""`[hmm] coupled` in the episode config: read, written, refused in one line, and the camera
perception's stripe HMMs it selects filter a synthetic row sequence differently."""

from __future__ import annotations

import numpy as np
import pytest

from perception.codes import EMPTY_CODE
from perception.hmm.online import OnlineStripeHmms
from sim import config
from sim.cli.main import main
from sim.errors import InvalidInput
from sim.sensing.perception import hmm_cache_path, stripe_models


def test_the_key_is_read_written_and_off_by_default():
    assert config.EpisodeConfig().hmm.coupled is False
    on = config.from_dict({"hmm": {"coupled": True}}, "c.toml")
    assert on.hmm.coupled is True
    assert on.to_dict()["hmm"] == {"coupled": True}
    assert config.from_dict(on.to_dict()) == on
    assert config.from_dict({}).to_dict()["hmm"] == {"coupled": False}


@pytest.mark.parametrize(
    ("table", "field"),
    [
        ({"hmm": {"coupled": "yes"}}, "hmm.coupled"),
        ({"hmm": {"coupled": 1}}, "hmm.coupled"),
        ({"hmm": {"neighbours": 2}}, "hmm.neighbours"),
        ({"hmm": True}, "hmm"),
    ],
)
def test_bad_values_are_refused_in_one_line(table, field):
    with pytest.raises(InvalidInput) as err:
        config.from_dict(table, "c.toml")
    text = str(err.value)
    assert err.value.field == field and "\n" not in text and "c.toml" in text


def test_the_command_line_refuses_it_before_any_work(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text('perception = "truth"\n[hmm]\ncoupled = "yes"\n')
    out = tmp_path / "out"
    assert main(["run", "--config", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "hmm.coupled" in err and "true | false" in err
    assert not out.exists()


def _rows(n_rows: int = 60) -> np.ndarray:
    """A synthetic flow of codes: an item passes stripe 2 every 6 rows and its neighbours
    (stripes 1 and 3) see an item in the rows before it."""
    rows = np.full((n_rows, 5), EMPTY_CODE, dtype=int)
    for start in range(0, n_rows - 3, 6):
        rows[start, (1, 3)] = 9  # medium and white, on the neighbours, one row earlier
        rows[start + 1 : start + 3, 2] = 5  # small and red, on the middle stripe
    return rows


def test_coupled_stripes_change_the_online_posteriors(catalogue):
    independent, _ = stripe_models(catalogue, coupled=False)
    coupled, _ = stripe_models(catalogue, coupled=True)
    assert independent.A.shape == (5, 1, 4, 4) and coupled.A.shape == (5, 4, 4, 4)
    assert hmm_cache_path(catalogue) != hmm_cache_path(catalogue, coupled=True)
    filtered = {}
    for name, models in (("independent", independent), ("coupled", coupled)):
        online = OnlineStripeHmms(models)
        filtered[name] = np.stack([online.step(row).filtered for row in _rows()])
    gap = np.abs(filtered["independent"] - filtered["coupled"])
    assert gap.max() > 1e-2  # the neighbours' states at t-1 move the middle stripe's belief
    assert np.allclose(filtered["coupled"].sum(axis=2), 1.0)


@pytest.mark.parametrize("coupled", [False, True])
def test_an_episodes_camera_perception_filters_with_the_configs_coupling(coupled):
    from sim.episode import builder
    from sim.episode.runner import config_cell

    episode_config = config.from_dict(
        {"perception": "camera", "items": 5, "duration_s": 5.0, "hmm": {"coupled": coupled}}
    )
    cell = config_cell(episode_config)
    flow = builder.episode_flow(episode_config, cell)
    perception = builder.perception(episode_config, cell, flow)
    try:
        neighbours = perception.hmm.base.A.shape[1]
        assert neighbours == (4 if coupled else 1)  # transitions per neighbour class at t-1
    finally:
        close = getattr(perception, "close", None)
        if close:
            close()
