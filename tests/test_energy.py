"""The motors' energy (sim.monitors.energy): the work-energy balance of MuJoCo's own
energy closes on the meter's signed work; holding still costs copper loss only; per-pick and
per-episode figures in the CSVs add up; the planners' energy price (planner.decision.energy_cost).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from planner.decision.energy_cost import EnergyPrice
from planner.errors import PlannerInputError
from sim import config
from sim.cell.idle_sleep import robot_trees
from sim.cell.robot import motor_qpos, set_motor_targets
from sim.episode.runner import run_episode
from sim.errors import InvalidInput
from sim.monitors.energy import ActuatorLog, DriveModel, EnergyMeter
from tests.utils import scene_at_home

PERIOD_S = 0.6
"""A motor-space move out and back: raised cosine, at rest at 0, PERIOD_S / 2 and PERIOD_S."""
AMPLITUDE_RAD = np.array([0.5, 0.3, 0.4])


def _hold(model, data, q, steps):
    for _ in range(steps):
        set_motor_targets(model, data, q, 0.0)
        mujoco.mj_step(model, data)


@pytest.fixture
def settled():
    model, data = scene_at_home()
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    q0 = motor_qpos(model, data).copy()
    _hold(model, data, q0, 300)
    return model, data, q0


def _move(model, data, q0, meter, until_s):
    """Play the raised-cosine move until `until_s`; the other forces' work on the way (passive
    and constraint, at each step's mean joint speed) [J]."""
    dt = model.opt.timestep
    other = 0.0
    for k in range(round(until_s / dt)):
        t = (k + 1) * dt
        phase = 2 * np.pi * t / PERIOD_S
        q = q0 + AMPLITUDE_RAD * (1 - np.cos(phase)) / 2
        qd = AMPLITUDE_RAD * np.pi / PERIOD_S * np.sin(phase)
        set_motor_targets(model, data, q, 0.0, qd)
        before = data.qvel.copy()
        mujoco.mj_step(model, data)
        mean = 0.5 * (before + data.qvel)
        other += float((data.qfrc_passive + data.qfrc_constraint) @ mean) * dt
        meter.add(dt)
    return other


@pytest.mark.parametrize("until_s", [PERIOD_S / 2, PERIOD_S])
def test_motor_work_closes_the_energy_balance(settled, until_s):
    """Motor work + passive + constraint work = change of kinetic + potential energy (MuJoCo's
    `data.energy`), within 1 % of the motors' absolute work: the meter reads the right forces
    with the right speeds. Half way the arms stand still, raised: the balance holds there too."""
    model, data, q0 = settled
    mujoco.mj_forward(model, data)
    energy0 = float(data.energy.sum())
    meter = EnergyMeter(model, data)
    other = _move(model, data, q0, meter, until_s)
    mujoco.mj_forward(model, data)
    change = float(data.energy.sum()) - energy0
    assert meter.mechanical_j > 3.0  # the move does real work
    assert meter.signed_j + other == pytest.approx(change, abs=0.01 * meter.mechanical_j)
    assert abs(meter.signed_j) <= meter.mechanical_j
    # Driving power over the efficiency, and copper loss on top: more than the work done.
    assert meter.electrical_j > max(meter.signed_j, 0.0) / DriveModel().efficiency


def test_holding_still_costs_copper_loss_only(settled):
    model, data, q0 = settled
    meter = EnergyMeter(model, data)
    dt, steps = model.opt.timestep, 500
    for _ in range(steps):
        set_motor_targets(model, data, q0, 0.0)
        mujoco.mj_step(model, data)
        meter.add(dt)
    tau = data.actuator_force[[model.actuator(n).id for n in ("motor_1", "motor_2", "motor_3")]]
    assert np.abs(tau).max() > 1.0  # the arms are held against gravity
    copper = float(np.sum((tau / DriveModel().arm_motor_constant) ** 2)) * dt * steps
    assert meter.mechanical_j < 1e-3
    assert meter.electrical_j == pytest.approx(copper, rel=0.02)


def test_drive_model_is_validated():
    with pytest.raises(InvalidInput, match="efficiency"):
        DriveModel(efficiency=1.5)
    with pytest.raises(InvalidInput, match="arm_motor_constant"):
        DriveModel(arm_motor_constant=0.0)


@pytest.fixture(scope="module")
def priced_runs(cell):
    """A short truth episode at no price and at a stress price (5000 EUR/kWh: a pick over
    1 m then costs about what an item is worth)."""
    base = dict(items=10, duration_s=8.0, perception="truth", planner="fifo", seed=5)
    return [
        run_episode(config.load(None, **base, energy_price_eur_per_kwh=price), cell=cell)
        for price in (0.0, 5000.0)
    ]


def test_pick_energies_add_up_to_at_most_the_episode(priced_runs):
    row, picks = priced_runs[0].episode_row, priced_runs[0].pick_rows
    assert picks and row["energy_elec_j"] > 0.0
    assert all(p["energy_elec_j"] > p["energy_mech_j"] * 0.5 > 0.0 for p in picks)
    assert all(0.1 < p["travel_m"] < 4.0 for p in picks)
    # Idle time between picks is counted in the episode, not in any pick.
    assert sum(p["energy_elec_j"] for p in picks) <= row["energy_elec_j"]
    assert sum(p["energy_mech_j"] for p in picks) <= row["energy_mech_j"] + 1e-6
    # 50 - 1000 J per pick: a delta robot's pick at 100 m/s^2, not milli- or kilojoules off.
    assert 50.0 < np.median([p["energy_elec_j"] for p in picks]) < 1000.0
    assert row["energy_cost_eur"] == 0.0 and row["net_profit_eur"] == row["profit_eur"]


def test_a_stress_price_is_charged_and_changes_the_picks(priced_runs):
    free, priced = (r.episode_row for r in priced_runs)
    cost = priced["energy_elec_j"] / 3.6e6 * 5000.0
    assert priced["energy_cost_eur"] == pytest.approx(cost, rel=1e-9)
    assert priced["net_profit_eur"] == pytest.approx(priced["profit_eur"] - cost)
    # Items that cost more than they earn are left (not all): fewer picks, less energy.
    assert 0 < priced["picked"] < free["picked"]
    assert priced["energy_elec_j"] < free["energy_elec_j"]


def test_energy_price_is_validated():
    with pytest.raises(InvalidInput, match="energy_price_eur_per_kwh"):
        config.load(None, energy_price_eur_per_kwh=-1.0)
    with pytest.raises(PlannerInputError, match="price_eur_per_kwh"):
        EnergyPrice(price_eur_per_kwh=float("nan"))


def test_energy_cost_is_linear_in_distance():
    price = EnergyPrice(price_eur_per_kwh=0.3, fixed_j=100.0, per_metre_j=200.0)
    assert price.cost_eur(1.0) == pytest.approx(300.0 / 3.6e6 * 0.3)
    assert np.all(EnergyPrice().cost_eur(np.array([0.5, 2.0])) == 0.0)


def test_power_is_the_documented_sums_bit_for_bit():
    """Driving power sums max(tau omega, 0) (written without the call): the same bits for
    braking, driving, signed zeros and non-finite readings."""
    model, data = scene_at_home()
    meter = EnergyMeter(model, data)
    ids = [model.actuator(name).id for name in ("motor_1", "motor_2", "motor_3", "axis4")]
    drive = DriveModel()
    inverse_km2 = [1.0 / drive.arm_motor_constant**2] * 3 + [1.0 / drive.axis4_motor_constant**2]
    steps = [  # (tau, omega): braking, driving, signed zeros; then inf - inf speeds (NaN power)
        ((-2.0, 0.5, -0.0, 3.0), (1.0, -0.0, 0.0, np.inf)),
        ((1.0, -0.0, 0.0, 0.5), (0.5, 0.0, -0.0, -np.inf)),
    ]
    for tau, speed in steps:
        last = data.actuator_velocity[ids].tolist()
        data.actuator_force[ids], data.actuator_velocity[ids] = tau, speed
        mechanical = driving = signed = copper = 0.0
        for f, v, v0, k in zip(tau, speed, last, inverse_km2, strict=True):
            power = f * (0.5 * (v + v0))
            mechanical, driving = mechanical + abs(power), driving + max(power, 0.0)
            signed, copper = signed + power, copper + f * f * k
        want = (mechanical, driving / drive.efficiency + copper, signed)
        assert np.array(meter.power_w()).tobytes() == np.array(want).tobytes()


def test_buffered_integration_is_step_by_step_to_the_bit():
    """`add` buffers the steps; the totals equal `power_w` integrated one step at a time
    (`mechanical_j += P dt` in order), over more steps than the buffer holds, with idle
    blocks' longer durations between them."""
    model, data = scene_at_home()
    meter = EnergyMeter(model, data)
    ids = [model.actuator(name).id for name in ("motor_1", "motor_2", "motor_3", "axis4")]
    drive = DriveModel()
    inverse_km2 = [1.0 / drive.arm_motor_constant**2] * 3 + [1.0 / drive.axis4_motor_constant**2]
    rng = np.random.default_rng(3)
    last = data.actuator_velocity[ids].tolist()
    want = [0.0, 0.0, 0.0]
    for step in range(2 * ActuatorLog.BUFFER_ROWS + 37):
        tau, speed = rng.normal(0.0, 20.0, 4), rng.normal(0.0, 3.0, 4)
        data.actuator_force[ids], data.actuator_velocity[ids] = tau, speed
        duration = 0.001 if step % 50 else 0.001 * (1 + step % 7)
        meter.add(duration)
        mechanical = driving = signed = copper = 0.0
        for f, v, v0, k in zip(tau.tolist(), speed.tolist(), last, inverse_km2, strict=True):
            power = f * (0.5 * (v + v0))
            mechanical, driving = mechanical + abs(power), driving + max(power, 0.0)
            signed, copper = signed + power, copper + f * f * k
        last = speed.tolist()
        electrical = driving / drive.efficiency + copper
        want = [
            w + p * duration for w, p in zip(want, (mechanical, electrical, signed), strict=True)
        ]
        if step in (5, ActuatorLog.BUFFER_ROWS + 3):  # a reading mid-way flushes the buffer
            assert meter.reading() == (want[0], want[1])
    assert (meter.mechanical_j, meter.electrical_j, meter.signed_j) == tuple(want)


def _step_by_step(rows, last_velocity, last_force):
    """Reference: (mechanical, electrical, signed) [J] of rows (tau, omega, duration, asleep),
    one step at a time; asleep, the robot holds the torques of its last awake step, still."""
    drive = DriveModel()
    inverse_km2 = [1.0 / drive.arm_motor_constant**2] * 3 + [1.0 / drive.axis4_motor_constant**2]
    want, last, held = [0.0, 0.0, 0.0], list(last_velocity), list(last_force)
    for tau, speed, duration, asleep in rows:
        tau, speed = (held, [0.0] * 4) if asleep else (list(tau), list(speed))
        mechanical = driving = signed = copper = 0.0
        for f, v, v0, k in zip(tau, speed, last, inverse_km2, strict=True):
            power = f * (0.5 * (v + v0))
            mechanical, driving = mechanical + abs(power), driving + max(power, 0.0)
            signed, copper = signed + power, copper + f * f * k
        last, held = speed, tau
        electrical = driving / drive.efficiency + copper
        want = [
            w + p * duration for w, p in zip(want, (mechanical, electrical, signed), strict=True)
        ]
    return want


def test_meters_sharing_a_log_meter_an_asleep_robot_holding_still_to_the_bit():
    """Two meters of one robot on one log, recorded once a step: the one that watches the
    robot's sleep counts the asleep steps with the torques of the robot's last awake step and
    no speed, the other as recorded; both equal the step-by-step sums to the bit, across
    the log's flushes and readings mid-way."""
    model, data = scene_at_home()
    tree = int(robot_trees(model)[0])
    log = ActuatorLog(data)
    ids = [model.actuator(name).id for name in ("motor_1", "motor_2", "motor_3", "axis4")]
    start = (data.actuator_velocity[ids].tolist(), data.actuator_force[ids].tolist())
    watching = EnergyMeter(model, data, asleep_tree=tree, log=log)
    plain = EnergyMeter(model, data, log=log)
    rng = np.random.default_rng(5)
    rows = []
    for step in range(2 * ActuatorLog.BUFFER_ROWS + 91):
        tau, speed = rng.normal(0.0, 20.0, 4), rng.normal(0.0, 3.0, 4)
        asleep = step < 3 or (step // 40) % 3 == 1  # asleep from the start, then in spells
        data.actuator_force[ids], data.actuator_velocity[ids] = tau, speed
        data.tree_asleep[tree] = 0 if asleep else -1
        duration = 0.001 if step % 50 else 0.001 * (1 + step % 7)
        log.record(duration)
        rows.append((tau.tolist(), speed.tolist(), duration, asleep))
        if step in (7, ActuatorLog.BUFFER_ROWS + 45):  # a reading mid-way
            assert watching.reading() == tuple(_step_by_step(rows, *start)[:2])
    assert [watching.mechanical_j, watching.electrical_j, watching.signed_j] == _step_by_step(
        rows, *start
    )
    awake = [(tau, speed, duration, False) for tau, speed, duration, _ in rows]
    assert [plain.mechanical_j, plain.electrical_j, plain.signed_j] == _step_by_step(awake, *start)
    assert watching.mechanical_j < 0.8 * plain.mechanical_j  # the asleep spells count
