"""Money as a plant counts it: values per kilogram, the `[economics]` section, the episode's
figures per hour and the payback of one more robot (`sim.results.economics`)."""

from __future__ import annotations

import math

import pytest

from sim import config as episode_config
from sim.config import EpisodeConfig, from_dict, mean_masses
from sim.episode.runner import run_episode
from sim.errors import InvalidInput
from sim.results.economics import payback_years, robot_cost_per_h

SHORT = {"perception": "truth", "items": 12, "duration_s": 5.0, "seed": 2}


def test_the_robots_cost_per_hour_and_the_payback():
    # 75 kEUR over 10 years of 4000 h, plus 3 kEUR a year: 1.875 + 0.75 EUR/h
    assert robot_cost_per_h(75000.0, 10.0, 4000.0, 3000.0) == pytest.approx(2.625)
    assert EpisodeConfig().economics.robot_cost_per_h_eur == pytest.approx(2.625)
    # 10 EUR/h more over 4000 h is 40 kEUR a year, 37 kEUR after maintenance
    assert payback_years(75000.0, 10.0, 4000.0, 3000.0) == pytest.approx(75000.0 / 37000.0)
    assert math.isinf(payback_years(75000.0, 0.75, 4000.0, 3000.0))  # covers maintenance only
    assert math.isinf(payback_years(75000.0, -1.0, 4000.0, 3000.0))


def test_values_per_kg_and_economics_are_read_and_written_back():
    data = {
        "values": {"plastic": 0.3, "per_kg": {"aluminium": 1.2, "cardboard_flat": 0.1}},
        "economics": {"robot_capital_eur": 90000.0, "energy_price_eur_per_kwh": 0.2},
    }
    config = from_dict(data)
    assert config.energy_price_eur_per_kwh == 0.2  # [economics]' price is the episode's
    table = config.to_dict()["values"]
    assert table["per_kg"] == {"aluminium": 1.2, "cardboard_flat": 0.1}
    assert "aluminium" not in table and table["plastic"] == 0.3  # per kg instead of per item
    assert from_dict(config.to_dict()) == config
    # the decision managers weigh aluminium at its mean item's mass
    values = config.values.for_planning(config.item_catalogue)
    planning = dict(zip(config.materials.names, values, strict=True))
    assert planning["aluminium"] == pytest.approx(
        1.2 * mean_masses(config.item_catalogue)["aluminium"]
    )
    assert planning["plastic"] == 0.3


@pytest.mark.parametrize(
    ("data", "field"),
    [
        ({"values": {"paper": 0.2, "per_kg": {"paper": 0.1}}}, "values.paper"),
        ({"values": {"per_kg": {"glass": 0.1}}}, "values.per_kg.glass"),
        ({"values": {"per_kg": {"paper": -1.0}}}, "values.per_kg.paper"),
        ({"values": {"per_kg": 0.1}}, "values.per_kg"),
        ({"economics": {"robot_life_years": 0.0}}, "economics.robot_life_years"),
        ({"economics": {"hours_per_year": 9000.0}}, "economics.hours_per_year"),
        ({"economics": {"interest": 0.05}}, "economics.interest"),
        (
            {"energy_price_eur_per_kwh": 0.1, "economics": {"energy_price_eur_per_kwh": 0.2}},
            "economics.energy_price_eur_per_kwh",
        ),
    ],
)
def test_bad_money_settings_are_refused_naming_the_key(data, field):
    with pytest.raises(InvalidInput) as refused:
        from_dict(data, "plant.toml")
    assert refused.value.field == field and refused.value.where == "plant.toml"


def test_the_energy_price_option_wins_over_the_files(tmp_path):
    path = tmp_path / "plant.toml"
    path.write_text("[economics]\nenergy_price_eur_per_kwh = 0.2\n")
    assert episode_config.load(path).energy_price_eur_per_kwh == 0.2
    assert episode_config.load(path, energy_price_eur_per_kwh=0.3).energy_price_eur_per_kwh == 0.3


def test_an_episode_priced_per_kg_earns_its_recovered_mass_times_the_price():
    """Every material at 1.5 EUR/kg: the profit is 1.5 x the kilograms in their own bins, and
    the figures per hour are the totals over the 5 s feed."""
    prices = {"paper": 1.5, "plastic": 1.5, "aluminium": 1.5}
    config = from_dict(
        {**SHORT, "values": {"per_kg": prices}, "economics": {"hours_per_year": 5000.0}}
    )
    row = run_episode(config).episode_row
    assert row["mass_recovered_kg"] > 0.0
    assert row["mass_recovered_kg"] <= row["mass_entered_kg"] + 1e-12
    assert row["profit_eur"] == pytest.approx(1.5 * row["mass_recovered_kg"], rel=1e-12)
    per_hour = 3600.0 / 5.0
    assert row["profit_per_h_eur"] == pytest.approx(row["net_profit_eur"] * per_hour)
    assert row["recovered_kg_per_h"] == pytest.approx(row["mass_recovered_kg"] * per_hour)
    recovered = row["picked"] - row["wrong_bin"]
    assert row["recovered_items_per_h"] == pytest.approx(recovered * per_hour)
    assert row["robot_cost_per_h_eur"] == pytest.approx(75000.0 / 50000.0 + 3000.0 / 5000.0)
    assert (row["robots"], row["hours_per_year"]) == (1, 5000.0)
