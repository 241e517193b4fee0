"""The calibrated regime's target, the paired finding's numbers and the sweeps of the regimes:
hand-computed values against the code, on the thesis's table and a small real episodes.csv."""

from __future__ import annotations

import csv
import math

import pytest

from sim.experiments.thesis import reproduce_calibrated, reproduce_paired
from sim.experiments.thesis.reproduce import DEFAULT_OUT, Run
from sim.experiments.thesis.thesis_rates import items_per_s, mean_items_per_s, timing
from sim.experiments.thesis.thesis_report import thesis_tables
from sim.results import outputs


def test_the_calibration_target_is_the_thesis_proximity_items_per_second():
    """Table 4.5: accuracy x items over Time, by hand (73.45 % of 80 = 58.76 items in 60.8 s...)."""
    by_hand = [58.76 / 60.8, 71.26 / 69.3, 104.25 / 88.7, 188.49 / 147.9, 246.8 / 187.3]
    t = thesis_tables()["4.5"]
    assert items_per_s(t, "proximity") == pytest.approx(by_hand, abs=1e-9)
    assert mean_items_per_s(t, "proximity") == pytest.approx(1.15243, abs=5e-5)


def test_the_thesis_timing_from_its_time_columns():
    """Its Q-learning ran 3.8 % (x1) and 5.7 % (x1.2) longer and picked 8.4 % and 6.8 % more
    items per second, means over the datasets; 64.02 / 60.8 = +5.30 % on the first, by hand."""
    t45, t46 = thesis_tables()["4.5"], thesis_tables()["4.6"]
    assert round(timing(t45).longer_pct, 1) == 3.8 and round(timing(t46).longer_pct, 1) == 5.7
    assert round(timing(t45).rate_pct, 1) == 8.4 and round(timing(t46).rate_pct, 1) == 6.8
    first = {k: [v[0]] if isinstance(v, list) else v for k, v in t45.items()}
    assert timing(first).longer_pct == pytest.approx(100 * (64.02 / 60.8 - 1), abs=1e-9)


# seed, planner, items, profit [EUR]: qlearning against proximity on two datasets, one flow
# (seed 3 at 10 items) that only qlearning ran.
EPISODES = [
    (0, "qlearning", 10, 11.0),
    (1, "qlearning", 10, 12.0),
    (2, "qlearning", 10, 9.0),
    (3, "qlearning", 10, 50.0),
    (0, "proximity", 10, 10.0),
    (1, "proximity", 10, 10.0),
    (2, "proximity", 10, 10.0),
    (0, "qlearning", 20, 22.0),
    (1, "qlearning", 20, 24.0),
    (2, "qlearning", 20, 21.0),
    (0, "proximity", 20, 20.0),
    (1, "proximity", 20, 20.0),
    (2, "proximity", 20, 20.0),
]


def test_the_paired_finding_on_a_small_episodes_csv(tmp_path):
    path = tmp_path / "episodes.csv"
    with path.open("w", newline="") as f:
        out = csv.writer(f)
        out.writerow(["seed", "planner", "n_items", "profit_eur"])
        out.writerows(EPISODES)
    rows = outputs.read_rows(path)
    by_items = reproduce_paired.pairs(rows, "qlearning", "proximity")
    assert by_items == {
        10: [(11.0, 10.0), (12.0, 10.0), (9.0, 10.0)],
        20: [(22, 20), (24, 20), (21, 20)],
    }
    # 10 items: gains +10, +20, -10 %: mean 6.667, sd 15.275, t(0.975, 2) = 4.3027.
    g = reproduce_paired.gain(by_items[10])
    half = 4.302653 * math.sqrt(700 / 3) / math.sqrt(3)
    assert (g.mean, g.low, g.high, g.n) == pytest.approx(
        (20 / 3, 20 / 3 - half, 20 / 3 + half, 3), abs=1e-4
    )
    # Pooled: +10, +20, -10, +10, +20, +5 %: mean 9.167, sd 11.143, t(0.975, 5) = 2.5706.
    pooled = reproduce_paired.gain([f for n in (10, 20) for f in by_items[n]])
    sd = math.sqrt(sum((x - 55 / 6) ** 2 for x in (10, 20, -10, 10, 20, 5)) / 5)
    assert pooled.mean == pytest.approx(55 / 6, abs=1e-9)
    assert pooled.high - pooled.mean == pytest.approx(2.570582 * sd / math.sqrt(6), abs=1e-4)
    # Slope of the EUR gains (1, 2, -1 at 10; 2, 4, 1 at 20): (2.333 - 0.667) / 10 a item;
    # residual variance 9.333 / 4, Sxx 150, t(0.975, 4) = 2.7764.
    s = reproduce_paired.slope(by_items)
    half = 2.776445 * math.sqrt((28 / 3) / 4 / 150)
    assert (s.per_100, s.low, s.high, s.n) == pytest.approx(
        (100 / 6, 100 * (1 / 6 - half), 100 * (1 / 6 + half), 6), abs=1e-3
    )
    row = reproduce_paired.comparison_row("r", 1.0, by_items, "qlearning - proximity", [10, 20, 30])
    assert row.startswith("| r | x1 | qlearning - proximity | +6.7 [-31.3, +44.6] | ")
    # 9.167 -+ 2.5706 x 11.143 / sqrt(6) = [-2.53, +20.86]; the slope's bounds as above.
    assert " | - | +9.2 [-2.5, +20.9] | +16.67 [-17.96, +51.3" in row


def test_the_regimes_run_the_flows_of_their_tables():
    """The calibrated sweeps: the flows of tables 4.5/4.6 (items, seeds, durations, belt) with
    their pauses, the five planners; the paused 4.2 and 4.4: their tables' flows, 0.5 s pauses."""
    run = Run(DEFAULT_OUT)

    def flows(name):
        return {
            (s.config.items, s.config.seed, s.config.duration_s, s.config.speed_factor)
            for s in run.sweep(name).episodes
        }

    def pauses(name):
        return {
            (r.pick_pause_s, r.place_pause_s)
            for s in run.sweep(name).episodes
            for r in s.config.robots
        }

    for table in ("4_5", "4_6"):
        name = f"reproduce_{table}_calibrated"
        assert flows(name) == flows(f"reproduce_{table}")
        assert {s.config.planner for s in run.sweep(name).episodes} == set(
            reproduce_calibrated.PLANNERS
        )
        assert pauses(name) == pauses(reproduce_calibrated.SWEEPS[0])
        assert len(pauses(name)) == 1 and 0 < min(pauses(name).pop()) < 0.5
    for table in ("4_2", "4_4"):
        assert flows(f"reproduce_{table}_paused") == flows(f"reproduce_{table}")
        assert pauses(f"reproduce_{table}_paused") == {(0.5, 0.5)}


@pytest.mark.parametrize(
    ("scale", "first", "verdict"),
    [(1.03, "0.995 (0.966)", "+3.0 %, within"), (0.90, "0.870 (0.966)", "-10.0 %, OUTSIDE")],
)
def test_the_calibration_check_compares_with_the_thesis(scale, first, verdict):
    """Rows whose proximity picks `scale` x the thesis's items per second at every dataset
    (80 items: 0.9664 x 1.03 = 0.995)."""
    t = thesis_tables()["4.5"]
    rows = [
        {"planner": "proximity", "n_items": str(n), "picked": str(100 * r * scale), "sim_s": "100"}
        for n, r in zip(t["items"], items_per_s(t, "proximity"), strict=True)
    ]
    text = "\n".join(reproduce_calibrated.calibration_lines(rows, t))
    assert f"| proximity, items/s | {first} | " in text
    assert f"({verdict} the 5 %" in text


def test_the_paired_block_from_rows_already_read(tmp_path):
    """The block as a run that has read its sweeps' rows makes it: the small episodes.csv as the
    calibrated x1 sweep's rows, no rows elsewhere; the thesis's timing printed from its table."""
    path = tmp_path / "episodes.csv"
    with path.open("w", newline="") as f:
        out = csv.writer(f)
        out.writerow(["seed", "planner", "n_items", "profit_eur"])
        out.writerows(EPISODES)
    run = Run(tmp_path / "out")
    for _, sweeps, _ in reproduce_paired.REGIMES:
        for name in sweeps:
            run._rows[name] = outputs.read_rows(path) if name == "reproduce_4_5_calibrated" else []
            run.seeds_of[name] = [0, 1, 2, 3]
    text = reproduce_paired.finding_paired(run).markdown
    assert "seeds 0-3 (4 per grid point), truth perception" in text.splitlines()[0]
    rows = [line for line in text.splitlines() if line.startswith("| calibrated")]
    assert rows == [
        "| calibrated | x1 | qlearning - proximity | +6.7 [-31.3, +44.6] | +11.7 [-7.3, +30.6] "
        "| +9.2 [-2.5, +20.9] | +16.67 [-17.96, +51.30] |"
    ]
    assert "- table 4.5 (x1): its Q-learning's Time was +3.8 % longer" in text
    assert "+8.4 % more items per second" in text and "+6.8 % more items per second" in text
