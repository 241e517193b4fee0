"""`sortsim advise`: its options refused in one line before any work, the verdicts of its
targets from the 95 % intervals, and a real (small, truth) sweep of lines answered."""

from __future__ import annotations

import math

import pytest

from sim.cli import main as cli
from sim.errors import InvalidInput
from sim.experiments.reporting import advice
from sim.results import outputs

MATERIALS = ("paper", "plastic", "aluminium")
PLANT = """duration_s = 8.0
[belt]
speed_mps = 0.2
[infeed]
items_per_m = 5.0
[flow]
mix = { paper = 0.40, plastic = 0.35, aluminium = 0.25 }
[values]
per_kg = { paper = 0.10, plastic = 0.30, aluminium = 1.20 }
"""
"""A small plant: 8 items over 8 s at 0.2 m/s (seconds of CPU an episode)."""


@pytest.mark.parametrize(
    "text",
    [
        "recovery.glass=0.9",  # no such material
        "speed=0.9",  # no such kind
        "purity=0",  # a level of 0 decides nothing
        "purity=1.5",
        "purity=high",
        "purity=0.9,purity=0.95",  # twice
    ],
)
def test_a_bad_target_is_refused_naming_what_is_allowed(text):
    with pytest.raises(InvalidInput) as err:
        advice.parse_targets(text, MATERIALS)
    assert err.value.field == "--targets" and "recovery[.paper|plastic|aluminium]" in str(err.value)


def test_targets_read_per_material_or_every_material():
    targets = advice.parse_targets("recovery.aluminium=0.9, purity=0.95", MATERIALS)
    assert [(t.name, t.level) for t in targets] == [("recovery.aluminium", 0.9), ("purity", 0.95)]
    row = {"recovery_aluminium": "0.8", "purity_paper": "0.99", "purity_plastic": "0.97"}
    row["purity_aluminium"] = ""  # an empty bin has no purity: the others decide
    assert targets[0].value(row, MATERIALS) == pytest.approx(0.8)
    assert targets[1].value(row, MATERIALS) == pytest.approx(0.97)


def test_a_verdict_is_read_from_the_interval_not_the_mean():
    target = advice.Target("recovery", "aluminium", 0.9)
    # mean 0.95, sd 0.0082 over 4 seeds: t(0.975, 3) 3.18 x 0.0041 -> [0.937, 0.963]: meets
    meets = advice.judged(target, [0.94, 0.95, 0.96, 0.95])
    assert meets.verdict == advice.MEETS and meets.low == pytest.approx(0.937, abs=1e-3)
    # mean 0.92 but wide: [0.79, 1.05] holds 0.9 on both sides: open
    assert advice.judged(target, [0.85, 0.99, 0.92]).verdict == advice.OPEN
    assert advice.judged(target, [0.70, 0.72, 0.71]).verdict == advice.FAILS
    assert advice.judged(target, [0.99]).verdict == advice.OPEN  # one seed decides nothing
    assert math.isnan(advice.judged(target, []).mean)


@pytest.mark.parametrize(
    ("options", "field"),
    [
        (["--robots", "1,5"], "--robots"),
        (["--robots", "2,2"], "--robots"),
        (["--perception", "lidar"], "--perception"),
        (["--max-seeds", "2"], "--max-seeds"),
        (["--belt-speeds", "fast"], "--belt-speeds"),
        (["--belt-speeds", "0.5"], "speed"),  # past the conveyor's range: the grid refuses it
        (["--targets", "recovery=2"], "--targets"),
        (["--workers", "0"], "--workers"),
    ],
)
def test_bad_options_are_refused_in_one_line_before_any_work(tmp_path, capsys, options, field):
    plant = tmp_path / "plant.toml"
    plant.write_text(PLANT)
    out = tmp_path / "out"
    code = cli.main(["advise", "--config", str(plant), "--out", str(out), *options])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and field in err[0]
    assert not out.exists()  # nothing written


def test_a_plant_config_with_a_table_of_robots_is_refused(tmp_path, capsys):
    plant = tmp_path / "plant.toml"
    plant.write_text("[[robots]]\npick_pause_s = 0.1\n" + PLANT)
    assert cli.main(["advise", "--config", str(plant), "--out", str(tmp_path / "o")]) == 2
    assert "robots" in capsys.readouterr().err


def test_a_small_sweep_of_lines_is_answered_and_its_runs_kept(tmp_path, capsys):
    plant = tmp_path / "plant.toml"
    plant.write_text(PLANT)
    out = tmp_path / "out"
    args = ["advise", "--config", str(plant), "--out", str(out), "--robots", "1,2"]
    args += ["--perception", "truth", "--max-seeds", "3", "--workers", "1"]
    args += ["--targets", "recovery=0.5,purity=0.9"]
    assert cli.main(args) == 0
    rows = outputs.read_rows(out / "episodes.csv")
    assert len(rows) == 6 and {r["robots"] for r in rows} == {"1", "2"}  # 2 lines x 3 seeds
    assert {round(float(r["belt_speed_mps"]), 3) for r in rows} == {0.2}
    text = (out / "advice.md").read_text()
    assert text.strip() in capsys.readouterr().out  # printed as written
    targets = advice.parse_targets("recovery=0.5,purity=0.9", MATERIALS)
    results = advice.line_results(rows, targets, MATERIALS)
    assert [r.line.robots for r in results] == [1, 2] and all(r.seeds == 3 for r in results)
    for result in results:
        assert f"| {result.line.name} | 3 |" in text
        assert result.profit_per_h_eur > 0 and result.payback_years > 0
    best = advice.ranked(results)
    if best:  # the answer names the cheapest line that meets the targets
        assert f"Recommended: {best[0].line.name}" in text
    else:
        assert "No line meets" in text
    assert "episodes in" in text and "CPU-min" in text
    # Asked again, the folder's episodes are found (a belt speed in m/s gives a speed factor
    # such as 1.08108..., which episodes.csv writes to 3 decimals): none is run twice.
    before = (out / "episodes.csv").read_bytes()
    assert cli.main(args) == 0
    assert (out / "episodes.csv").read_bytes() == before
