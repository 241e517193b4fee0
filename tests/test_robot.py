"""The closed chain in motion: servos driven through the workspace at 10 m/s and 100 m/s^2.

Figures (printed with `pytest -s tests/test_robot.py`): platform tilt and loop-closure maxima,
TCP tracking error, peak motor torque, and the robot's step cost.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
import pytest

from planner.motion.kinematics import forward_kinematics, inverse_kinematics, is_reachable, jacobian
from sim.cell.robot import (
    geometry_from_model,
    loop_closure_error,
    motor_qpos,
    motor_qvel,
    platform_tilt,
    set_configuration,
    set_motor_targets,
    tcp_position,
)
from sim.model.mjcf import load_robot

V_MAX = 10.0  # ABB's maximum TCP speed [m/s]
A_MAX = 100.0  # ABB's maximum TCP acceleration [m/s^2]


def trapezoid(p0: np.ndarray, p1: np.ndarray, v_max: float, a_max: float):
    """Straight move with a trapezoidal speed profile; returns (duration [s], f(t) -> (p, v))."""
    length = float(np.linalg.norm(p1 - p0))
    u = (p1 - p0) / length
    t_acc = v_max / a_max
    if a_max * t_acc**2 > length:  # never reaches v_max: triangular profile
        t_acc = np.sqrt(length / a_max)
        v_max = a_max * t_acc
    t_cruise = (length - a_max * t_acc**2) / v_max
    total = 2.0 * t_acc + t_cruise

    def at(t: float):
        if t < t_acc:
            s, v = 0.5 * a_max * t * t, a_max * t
        elif t < t_acc + t_cruise:
            s, v = 0.5 * a_max * t_acc**2 + v_max * (t - t_acc), v_max
        elif t < total:
            r = total - t
            s, v = length - 0.5 * a_max * r * r, a_max * r
        else:
            s, v = length, 0.0
        return p0 + s * u, v * u

    return total, at


def workspace_tour(radius: float = 0.55, z: float = 0.05) -> list[np.ndarray]:
    """A pentagram of 1.05 m chords across the working circle, then moves up, down and across."""
    angles = np.deg2rad(np.arange(6) * 144.0 + 18.0)
    points = [np.array([radius * np.cos(a), radius * np.sin(a), z]) for a in angles]
    points += [np.array([0.0, 0.0, 0.25]), np.array([0.3, 0.0, 0.0]), np.array([-0.3, 0.3, 0.2])]
    return points


@pytest.fixture(scope="module")
def model():
    return load_robot()


def test_set_configuration_closes_the_loop_at_the_fk_pose(model):
    data = mujoco.MjData(model)
    geom = geometry_from_model(model)
    for q in ([0.1, 0.5, 0.9], [-0.4, 0.2, 1.2], [1.0, 1.0, 1.0]):
        set_configuration(model, data, q, axis4=0.7)
        assert loop_closure_error(model, data) < 1e-8
        assert platform_tilt(model, data) < 1e-12
        np.testing.assert_allclose(
            tcp_position(model, data), forward_kinematics(geom, q), atol=1e-8
        )
        np.testing.assert_allclose(motor_qpos(model, data), q, atol=0)
        assert data.joint("axis4_joint").qpos[0] == pytest.approx(0.7)


def test_home_keyframe_is_ik_consistent(model):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    geom = geometry_from_model(model)
    assert loop_closure_error(model, data) < 1e-8
    np.testing.assert_allclose(inverse_kinematics(geom, tcp_position(model, data)), data.ctrl[:3])


def test_velocity_lead_makes_the_servo_track_speed(model):
    data = mujoco.MjData(model)
    set_configuration(model, data, [0.3, 0.3, 0.3])
    set_motor_targets(model, data, [0.3, 0.3, 0.3], 0.0, qdot=[2.0, -1.0, 0.0])
    kp = model.actuator("motor_1").gainprm[0]
    kv = -model.actuator("motor_1").biasprm[2]
    np.testing.assert_allclose(data.ctrl[:3], 0.3 + kv / kp * np.array([2.0, -1.0, 0.0]))


def test_level_and_closed_at_10_mps_and_100_mps2(model):
    data = mujoco.MjData(model)
    geom = geometry_from_model(model)
    points = workspace_tour()
    assert all(is_reachable(geom, p) for p in points)
    set_configuration(model, data, inverse_kinematics(geom, points[0]))
    dt = model.opt.timestep
    tilt = loop = track = speed = torque = 0.0
    for p0, p1 in zip(points[:-1], points[1:], strict=True):
        duration, at = trapezoid(p0, p1, V_MAX, A_MAX)
        for k in range(int(np.ceil(duration / dt)) + 100):  # then 0.1 s to settle
            p, v = at((k + 1) * dt)
            q = inverse_kinematics(geom, p)
            set_motor_targets(model, data, q, 0.0, qdot=np.linalg.solve(jacobian(geom, q), v))
            mujoco.mj_step(model, data)
            tilt = max(tilt, platform_tilt(model, data))
            loop = max(loop, loop_closure_error(model, data))
            track = max(track, float(np.linalg.norm(tcp_position(model, data) - p)))
            speed = max(speed, float(np.linalg.norm(v)))
            torque = max(torque, float(np.max(np.abs(data.actuator_force[:3]))))
    print(
        f"\n{V_MAX} m/s, {A_MAX} m/s^2 tour: max tilt {tilt:.3e} rad, max loop gap {loop:.3e} m, "
        f"max tracking error {track * 1e3:.1f} mm, peak motor torque {torque:.1f} N m"
    )
    assert speed == pytest.approx(V_MAX)
    assert tilt < 1e-3
    assert loop < 1e-4
    assert sum(w.number for w in data.warning) == 0
    # Settled at the last point: the servo reached the goal.
    assert np.linalg.norm(tcp_position(model, data) - points[-1]) < 1e-3
    assert np.max(np.abs(motor_qvel(model, data))) < 0.05


def test_step_cost_of_the_robot_alone(model):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    rng = np.random.default_rng(0)
    lo, hi = model.actuator_ctrlrange[:3].T
    steps = 2000
    start = time.perf_counter()
    for k in range(steps):
        if k % 200 == 0:
            data.ctrl[:3] = rng.uniform(0.5 * lo, 0.5 * hi)
        mujoco.mj_step(model, data)
    cost = (time.perf_counter() - start) / steps
    print(f"\nrobot alone: {cost * 1e6:.1f} us per {model.opt.timestep * 1e3:.0f} ms step")
    assert cost < 1e-3  # far faster than real time even on a loaded machine


def peak_torque_of_cycle1_moves(payload_kg: float, accel: float) -> float:
    """Peak motor torque [N m] for Cycle 1's 305 mm stroke there and back at `accel` [m/s^2],
    payload lumped into the cup, torque limit lifted so the demand is measured, not clipped."""
    model = load_robot()
    model.actuator_forcerange[:] = (-1e4, 1e4)
    cup = model.body("cup_link").id
    model.body_mass[cup] += payload_kg
    model.body_inertia[cup] += payload_kg * 0.03**2 / 6.0  # 60 mm cube
    data = mujoco.MjData(model)
    geom = geometry_from_model(model)
    a, b = np.array([-0.1525, 0.0, 0.05]), np.array([0.1525, 0.0, 0.05])
    set_configuration(model, data, inverse_kinematics(geom, a))
    dt, peak = model.opt.timestep, 0.0
    for p0, p1 in ((a, b), (b, a)):
        duration, at = trapezoid(p0, p1, V_MAX, accel)
        for k in range(int(np.ceil(duration / dt)) + 50):
            p, v = at((k + 1) * dt)
            q = inverse_kinematics(geom, p)
            set_motor_targets(model, data, q, 0.0, qdot=np.linalg.solve(jacobian(geom, q), v))
            mujoco.mj_step(model, data)
            peak = max(peak, float(np.max(np.abs(data.actuator_force[:3]))))
    return peak


def test_torque_limit_allows_cycle1_at_1kg_but_not_at_3kg(model):
    """Cycle 1 at 150 cycles/min needs about 50 m/s^2 on its 305 mm stroke (README, "Motors"):
    within the torque limit with 1 kg, beyond it with 3 kg (ABB: 115 cycles/min at 3 kg)."""
    limit = model.actuator("motor_1").forcerange[1]
    at_1kg = peak_torque_of_cycle1_moves(1.0, 50.0)
    at_3kg = peak_torque_of_cycle1_moves(3.0, 50.0)
    print(
        f"\nCycle 1 stroke at 50 m/s^2: peak torque {at_1kg:.0f} N m (1 kg), "
        f"{at_3kg:.0f} N m (3 kg)"
    )
    assert at_1kg < limit < at_3kg
