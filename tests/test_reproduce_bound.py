"""The piece `bound_4_5_4_6`: the bound computed on a tiny sweep's real flows, the planners' rows
from a small real episodes.csv, the paired headroom by hand, "not run" where a regime has no
sweep of a planner, and the physics runs above the bound counted."""

from __future__ import annotations

import csv
import math

import pytest

from sim.experiments.thesis import reproduce_bound as bound
from sim.experiments.thesis.reproduce import Run
from sim.results import outputs

SWEEP = "reproduce_4_5_paused_best_order"


def _tiny_sweep(folder, name, items=12, seeds=2, duration_s=4.0):
    """`name`'s sweep: `items` over `duration_s` [s] at x1 (x1.2 for 4.6), the thesis's pauses
    where the name says paused, best_order, truth."""
    speed = 1.2 if "4_6" in name else 1.0
    pauses = "\n[base.robot]\npick_pause_s = 0.5\nplace_pause_s = 0.5\n" if "paused" in name else ""
    (folder / f"{name}.toml").write_text(
        f'[sweep]\nname = "{name}"\nspeed_factors = [{speed}]\nitems = [{items}]\n'
        f'planners = ["best_order"]\nseeds = {seeds}\n\n'
        f'[base]\nperception = "truth"\nduration_s = {duration_s}\n{pauses}'
    )


def _episodes(path, rows):
    with path.open("w", newline="") as f:
        out = csv.writer(f)
        out.writerow(["seed", "planner", "n_items", "profit_eur"])
        out.writerows(rows)
    return outputs.read_rows(path)


def test_the_bound_table_of_one_regime(tmp_path):
    _tiny_sweep(tmp_path, SWEEP)
    run = Run(tmp_path / "out", experiments=tmp_path)
    bounds = bound.bound_rows(run, SWEEP)
    assert [(r["n_items"], r["seed"]) for r in bounds] == [(12, "0"), (12, "1")]
    b0, b1 = (r["profit_eur"] for r in bounds)
    # 12 items in 4 s with 0.5 s pauses after each pick and place: not all can be met.
    from sim.evaluation.flow_bound import flow_facts

    for spec, b in zip(run.sweep(SWEEP).episodes, (b0, b1), strict=True):
        assert 1.2 < b < float(flow_facts(spec.config).values.sum()) - 0.5
    # proximity 1.2 and 1.5 EUR; the best order 1.32 and 1.5; qlearning above seed 0's bound.
    rows = _episodes(
        tmp_path / "episodes.csv",
        [
            (0, "proximity", 12, 1.2),
            (1, "proximity", 12, 1.5),
            (0, "best_order", 12, 1.32),
            (1, "best_order", 12, 1.5),
            (0, "qlearning", 12, round(b0 + 1.0, 2)),
        ],
    )
    lines = bound.regime_table(rows + bounds)
    assert lines[0].startswith("| items | bound | best_order | qlearning | rollout | lookahead |")
    row = lines[2].split(" | ")
    assert row[1] == f"{(b0 + b1) / 2:.2f}" and row[2] == "1.41" and row[3] == f"{b0 + 1.0:.2f}"
    assert row[4:6] == ["not run", "not run"] and row[6] == "1.35" and row[7] == "not run"
    # The best order: +10 % and 0 %: mean +5 %, sd 7.071, t(0.975, 1) = 12.706: +-63.5.
    assert row[9].rstrip(" |") == "+5.0 [-58.5, +68.5]"
    gains = [100 * (b0 - 1.2) / 1.2, 100 * (b1 - 1.5) / 1.5]
    half = 12.7062 * abs(gains[0] - gains[1]) / 2
    mean = sum(gains) / 2
    assert row[8] == f"{mean:+.1f} [{mean - half:+.1f}, {mean + half:+.1f}]"
    assert lines[3].endswith(f"| {row[8]} | +5.0 [-58.5, +68.5] |")
    assert lines[-1] == "Physics runs that earned more than their flow's bound: 1 of 5."


def test_the_block_names_its_regimes_and_says_what_the_bound_is(tmp_path):
    """Every regime's table, its sweeps' rows already read (empty but one), the bound on one
    3-item flow a sweep."""
    for _, _, names in bound.REGIMES:
        _tiny_sweep(tmp_path, bound.best_sweep(names), items=3, seeds=1, duration_s=3.0)
    run = Run(tmp_path / "out", experiments=tmp_path)
    rows = _episodes(
        tmp_path / "episodes.csv", [(0, "lookahead", 3, 0.5), (0, "proximity", 3, 0.4)]
    )
    for name in bound.sweeps():
        run._rows[name] = rows if name == "reproduce_4_5_calibrated" else []
        run.seeds_of[name] = [0]
    text = bound.bound_block(run).markdown
    first = text.splitlines()[0]
    assert "--only bound_4_5_4_6" in first and "seeds 0 (1 per grid point)" in first
    assert "upper bound under the cycle-time model, not proven for the physics' robot" in text
    heads = [line for line in text.splitlines() if line.startswith("**")]
    assert heads == [
        "**physical cycle, table 4.5 (x1)**",
        "**physical cycle, table 4.6 (x1.2)**",
        "**the thesis's pauses, table 4.5 (x1)**",
        "**the thesis's pauses, table 4.6 (x1.2)**",
        "**calibrated, table 4.5 (x1)**",
        "**calibrated, table 4.6 (x1.2)**",
    ]
    calibrated = text.split("**calibrated, table 4.5 (x1)**")[1].split("**")[0]
    row = next(line for line in calibrated.splitlines() if line.startswith("| 3 |")).split(" | ")
    assert row[5:7] == ["0.50", "0.40"] and row[3] == "not run"
    assert not math.isnan(float(row[1]))


def test_best_order_needs_its_flow():
    from planner.decision.registry import FLOW_PLANNERS, PLANNERS, make_planner
    from planner.errors import PlannerInputError

    assert "best_order" in FLOW_PLANNERS and "best_order" not in PLANNERS
    with pytest.raises(PlannerInputError, match="best_order"):
        make_planner("best_order")
