"""ABB's Cycle 1 in physics against the datasheet, and the `sortsim cycle` command."""

from __future__ import annotations

import json

import pytest

from sim.cli.main import main as cli_main
from sim.evaluation.cycle1 import run_cycle1

ABB_1KG_S = 60.0 / 150.0  # IRB 360-3/1130: 150 cycles/min at 0.1 kg and at 1 kg


@pytest.fixture(scope="module")
def reports():
    return {m: run_cycle1(m) for m in (0.1, 1.0, 3.0)}


def test_cycle1_1kg_matches_abb(reports):
    r = reports[1.0]
    assert abs(r.cycle_time_s - ABB_1KG_S) <= 0.10 * ABB_1KG_S
    assert r.peak_torque_ratio < 1.0  # never saturates
    assert r.tracking_error_pick_mm < 1.0 and r.tracking_error_place_mm < 1.0
    assert r.payload_held and r.vacuum_cup_holds
    assert r.platform_tilt_max_rad < 1e-3


def test_cycle1_light_payload_same_rating(reports):
    r = reports[0.1]
    assert abs(r.cycle_time_s - ABB_1KG_S) <= 0.10 * ABB_1KG_S
    assert r.peak_torque_ratio < 1.0
    assert max(r.tracking_error_pick_mm, r.tracking_error_place_mm) < 1.0


def test_cycle1_3kg_slower_within_limits(reports):
    r3, r1 = reports[3.0], reports[1.0]
    assert r3.cycle_time_s > r1.cycle_time_s * 1.15  # ABB: 115 vs 150 per minute
    assert abs(r3.cycles_per_min - 115.0) <= 0.10 * 115.0
    assert r3.peak_torque_ratio < 1.0
    assert max(r3.tracking_error_pick_mm, r3.tracking_error_place_mm) < 1.0
    assert r3.payload_held
    # The cup's load is checked, not assumed: 3 kg loads it about twice as hard as 1 kg.
    assert r3.payload_peak_load_n > 1.5 * r1.payload_peak_load_n
    assert r3.vacuum_cup_holds == (r3.payload_peak_load_n <= r3.vacuum_cup_budget_n)


def test_cycle_is_deterministic():
    assert run_cycle1(1.0) == run_cycle1(1.0)


def test_cli_json_and_refusal(capsys):
    assert cli_main(["cycle", "--payload", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert abs(out["cycle_time_s"] - ABB_1KG_S) <= 0.10 * ABB_1KG_S
    assert out["payload_held"] is True
    assert cli_main(["cycle", "--payload", "3.5"]) == 2
    err = capsys.readouterr().err
    assert "--payload" in err and "0 to 3" in err and len(err.strip().splitlines()) == 1


def test_cli_text(capsys):
    assert cli_main(["cycle", "--payload", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "cycles per minute" in out and "ABB: 150/min" in out and "payload held" in out


def test_torque_feedforward_is_what_makes_1mm():
    """Without the lumped-model feed-forward the servos lag the 1 kg cycle by millimetres."""
    import mujoco
    import numpy as np

    from planner.motion.kinematics import inverse_kinematics
    from planner.motion.limits import limits_for_payload
    from planner.motion.pick_cycle import plan_cycle1
    from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
    from sim.cell.executor import TrajectoryExecutor, lumped_dynamics
    from sim.cell.robot import geometry_from_model, set_configuration
    from sim.evaluation.cycle1 import CYCLE1_START, model_with_payload

    model = model_with_payload(0.0)
    geom = geometry_from_model(model)
    gen = RuckigTrajectoryGenerator(limits_for_payload(1.0), geom, lumped_dynamics(model, geom))
    a = np.array(CYCLE1_START)
    chain = plan_cycle1(a, gen)
    errors = {}
    for ff in (True, False):
        data = mujoco.MjData(model)
        set_configuration(model, data, inverse_kinematics(geom, a), 0.0)
        log = TrajectoryExecutor(model, data, geometry=geom, feedforward=ff).execute(chain)
        errors[ff] = log.error_at(chain.phase_start("vacuum_place"))
    assert errors[True] < 1e-3 < errors[False]
