"""Analytic delta kinematics against MuJoCo's kinematics of the closed-chain MJCF.

Figures (printed with `pytest -s tests/test_kinematics.py`): FK error, IK round trip, Jacobian
error and the workspace band over which the full 1130 mm cylinder is reachable.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from planner.errors import PlannerInputError
from planner.motion.kinematics import (
    DeltaGeometry,
    Unreachable,
    forward_kinematics,
    inverse_kinematics,
    is_reachable,
    jacobian,
    reachable_mask,
)
from sim.cell.robot import (
    MOTOR_JOINTS,
    geometry_from_model,
    set_configuration,
    settle_loop,
    tcp_position,
)
from sim.model.mjcf import load_scene

N_CONFIGS = 500
WORKING_RADIUS = 0.565  # half of ABB's 1130 mm working diameter [m]


@pytest.fixture(scope="module")
def model():
    return load_scene()


@pytest.fixture(scope="module")
def geom(model):
    return geometry_from_model(model)


def elbows_out(geom: DeltaGeometry, q: np.ndarray, p: np.ndarray) -> bool:
    """True when every elbow lies above the motor-axis-to-platform-joint line (the IRB 360's
    assembly mode; the other branch puts the elbows inside and the arms through the rods)."""
    platform = p + np.array([0.0, 0.0, geom.tcp_offset])
    for leg in range(3):
        u = geom.radial[leg]
        axis = geom.base_centre + geom.base_radius * u
        d = platform + geom.platform_radius * u - axis
        d_radial, d_down = d @ u, -d[2]
        e_radial, e_down = np.cos(q[leg]), np.sin(q[leg])
        if e_radial * d_down - e_down * d_radial <= 0.0:
            return False
    return True


def random_reachable_configs(geom: DeltaGeometry, n: int, seed: int) -> np.ndarray:
    """`n` motor configurations (seeded) whose FK lies in the workspace, elbows out."""
    rng = np.random.default_rng(seed)
    found = []
    while len(found) < n:
        q = rng.uniform(geom.motor_lower, geom.motor_upper, size=(4 * n, 3))
        ok = np.ones(len(q), dtype=bool)
        p = np.full((len(q), 3), np.nan)
        for k, qk in enumerate(q):
            try:
                p[k] = forward_kinematics(geom, qk)
            except PlannerInputError:
                ok[k] = False
                continue
            ok[k] = elbows_out(geom, qk, p[k])
        ok &= reachable_mask(geom, np.nan_to_num(p))
        found.extend(q[ok])
    return np.array(found[:n])


def test_geometry_read_from_model_matches_datasheet(geom):
    assert geom.base_radius == pytest.approx(0.200, abs=1e-9)
    assert geom.upper_arm == pytest.approx(0.350, abs=1e-12)
    assert geom.forearm == pytest.approx(0.800, abs=1e-12)
    assert geom.rod_spacing == pytest.approx(0.100, abs=1e-12)
    assert np.rad2deg(geom.motor_lower) == pytest.approx(-46.0, abs=0.01)
    assert np.rad2deg(geom.motor_upper) == pytest.approx(100.0, abs=0.01)
    np.testing.assert_allclose(np.rad2deg(geom.leg_azimuths), [0.0, 120.0, 240.0], atol=1e-6)


def test_fk_matches_mujoco_after_settling_the_loop(model, geom):
    """Motors set, passive joints started off by ~0.05 rad and closed by MuJoCo's kinematics."""
    data = mujoco.MjData(model)
    rng = np.random.default_rng(7)
    worst = 0.0
    for q in random_reachable_configs(geom, N_CONFIGS, seed=1):
        set_configuration(model, data, q + rng.normal(0.0, 0.05, 3))
        for name, angle in zip(MOTOR_JOINTS, q, strict=True):
            data.joint(name).qpos[0] = angle
        assert settle_loop(model, data) < 1e-10
        worst = max(
            worst, float(np.linalg.norm(tcp_position(model, data) - forward_kinematics(geom, q)))
        )
    print(f"\nFK vs MuJoCo over {N_CONFIGS} configurations: max error {worst:.3e} m")
    assert worst < 1e-4


def test_ik_inverts_fk(geom):
    q = random_reachable_configs(geom, N_CONFIGS, seed=2)
    back = inverse_kinematics(geom, forward_kinematics(geom, q))
    err = np.max(np.abs(back - q))
    print(f"\nIK(FK(q)) - q over {N_CONFIGS} configurations: max {err:.3e} rad")
    assert err < 1e-9


def test_vectorised_and_single_calls_agree(geom):
    q = random_reachable_configs(geom, 20, seed=3)
    p, jac = forward_kinematics(geom, q), jacobian(geom, q)
    for qk, pk, jk in zip(q, p, jac, strict=True):
        np.testing.assert_allclose(forward_kinematics(geom, qk), pk, atol=1e-15)
        np.testing.assert_allclose(inverse_kinematics(geom, pk), qk, atol=1e-12)
        np.testing.assert_allclose(jacobian(geom, qk), jk, atol=1e-15)


def test_jacobian_matches_central_differences(geom):
    h = 1e-6
    worst = 0.0
    for q in random_reachable_configs(geom, 200, seed=4):
        jac = jacobian(geom, q)
        num = np.empty((3, 3))
        for j in range(3):
            dq = np.zeros(3)
            dq[j] = h
            num[:, j] = (forward_kinematics(geom, q + dq) - forward_kinematics(geom, q - dq)) / (
                2 * h
            )
        worst = max(worst, float(np.max(np.abs(jac - num))))
    print(f"\nJacobian vs central differences (h = 1e-6 rad): max {worst:.3e} m/rad")
    assert worst < 1e-7


def workspace_band(geom: DeltaGeometry, radius: float, step: float = 0.0025):
    """Lowest and highest TCP z [m] between which the whole disc of `radius` is reachable."""
    radii = np.linspace(0.0, radius, 24)
    angles = np.linspace(0.0, 2.0 * np.pi, 240, endpoint=False)
    rr, aa = np.meshgrid(radii, angles)
    disc = np.stack([rr.ravel() * np.cos(aa.ravel()), rr.ravel() * np.sin(aa.ravel())], axis=1)
    disc += np.asarray(geom.base_xy)
    zs = np.arange(geom.base_height - 1.4, geom.base_height - 0.3, step)
    full = [bool(reachable_mask(geom, np.c_[disc, np.full(len(disc), z)]).all()) for z in zs]
    inside = zs[np.array(full)]
    assert inside.size, "no height at which the whole disc is reachable"
    # The band must be one contiguous run of heights.
    assert np.allclose(np.diff(inside), step)
    return float(inside.min()), float(inside.max())


def test_workspace_covers_1130_cylinder_from_belt_to_250_mm(geom):
    low, high = workspace_band(geom, WORKING_RADIUS)
    print(f"\nFull 1130 mm disc reachable for TCP z in [{low:.4f}, {high:.4f}] m (world)")
    assert low <= 0.0 and high >= 0.25


def test_bin_drop_points_and_belt_are_reachable(model, geom):
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for name in ("bin_paper_drop", "bin_plastic_drop", "bin_aluminium_drop"):
        assert is_reachable(geom, data.site(name).xpos), name
    # The cup can touch a flat item anywhere on the belt inside the working circle.
    for y in np.linspace(-0.4, 0.4, 9):
        for x in np.linspace(-0.4, 0.4, 9):
            if np.hypot(x, y) <= WORKING_RADIUS:
                assert is_reachable(geom, [x, y, 0.005])


def test_unreachable_positions_are_refused(geom):
    assert not is_reachable(geom, [0.0, 0.0, 2.0])
    assert not is_reachable(geom, [1.5, 0.0, 0.1])
    with pytest.raises(Unreachable, match="workspace"):
        inverse_kinematics(geom, [0.9, 0.0, 0.1])
    with pytest.raises(PlannerInputError):
        inverse_kinematics(geom, [0.0, 0.0])


def test_geometry_validates_eagerly():
    with pytest.raises(PlannerInputError, match="forearm"):
        DeltaGeometry(forearm=-0.8)
    with pytest.raises(PlannerInputError, match="motor_lower"):
        DeltaGeometry(motor_lower=1.0, motor_upper=0.5)
