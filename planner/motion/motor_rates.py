"""Motor angles, speeds and accelerations of a TCP motion, in closed form from the leg loops.

Each leg closes the loop |P + r u_i - E_i(q_i)| = L (platform joint point P, elbow E_i, rod
length L). With rho_i = P + r u_i - E_i and b_i = rho_i . dE_i/dq_i, differentiating once and
twice gives qd_i = rho_i . v / b_i and
qdd_i = (|v - dE_i/dq_i qd_i|^2 + rho_i . a - rho_i . d2E_i/dq_i^2 qd_i^2) / b_i,
exact and far cheaper than differentiating the Jacobian numerically. The Jacobian follows as
J = dp/dq = R^-1 diag(b) (rows of R: rho_i), as `planner.motion.kinematics.jacobian` computes it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from planner.motion.kinematics import DeltaGeometry, elbows_from_cos_sin, inverse_kinematics

_Z = np.array([0.0, 0.0, 1.0])


class MotorRates(NamedTuple):
    """Motor state along a sampled TCP motion, each (n, 3) [rad, rad/s, rad/s^2]; `jac` is
    dp/dq (n, 3, 3) [m/rad]."""

    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    jac: np.ndarray


def motor_rates(geom: DeltaGeometry, xyz, vxyz, axyz=None) -> MotorRates:
    """Motor angles, speeds, accelerations and Jacobians for TCP positions, velocities and
    accelerations (n, 3) [m, m/s, m/s^2] (accelerations zero when omitted).

    Raises:
        planner.motion.kinematics.Unreachable: a position outside the workspace.
    """
    xyz = np.atleast_2d(np.asarray(xyz, dtype=float))
    return motor_rates_at_angles(geom, inverse_kinematics(geom, xyz), xyz, vxyz, axyz)


def motor_rates_at_angles(geom: DeltaGeometry, q, xyz, vxyz, axyz=None) -> MotorRates:
    """`motor_rates` where the motor angles `q` (n, 3) [rad] of the TCP positions `xyz`
    (n, 3) [m] are known already (`planner.motion.kinematics.angles_and_reachability`)."""
    xyz = np.atleast_2d(np.asarray(xyz, dtype=float))
    v = np.atleast_2d(np.asarray(vxyz, dtype=float))
    a = np.zeros_like(v) if axyz is None else np.atleast_2d(np.asarray(axyz, dtype=float))
    u = geom.radial
    platform = xyz + np.array([0.0, 0.0, geom.tcp_offset])
    cq, sq = np.cos(q)[..., None], np.sin(q)[..., None]
    rho = platform[:, None, :] + geom.platform_radius * u - elbows_from_cos_sin(geom, cq, sq)
    d_elbow = geom.upper_arm * (-sq * u - cq * _Z)  # dE/dq
    dd_elbow = geom.upper_arm * (-cq * u + sq * _Z)  # d2E/dq2
    b = np.einsum("nij,nij->ni", rho, d_elbow)
    qdot = np.einsum("nij,nj->ni", rho, v) / b
    rel = v[:, None, :] - d_elbow * qdot[..., None]
    num = np.sum(rel * rel, axis=-1) + np.einsum("nij,nj->ni", rho, a)
    num -= np.einsum("nij,nij->ni", rho, dd_elbow) * qdot**2
    jac = np.linalg.solve(rho, b[:, :, None] * np.eye(3)[None])
    return MotorRates(q, qdot, num / b, jac)
