"""Motor angles, speeds and accelerations of a TCP motion, in closed form from the leg loops.

Each leg closes the loop |P + r u_i - E_i(q_i)| = L (platform joint point P, elbow E_i, rod
length L). With rho_i = P + r u_i - E_i and b_i = rho_i . dE_i/dq_i, differentiating once and
twice gives qd_i = rho_i . v / b_i and
qdd_i = (|v - dE_i/dq_i qd_i|^2 + rho_i . a - rho_i . d2E_i/dq_i^2 qd_i^2) / b_i,
exact and far cheaper than differentiating the Jacobian numerically. The Jacobian follows as
J = dp/dq = R^-1 diag(b) (rows of R: rho_i), as `planner.motion.kinematics.jacobian` computes it.

The per-leg vectors are built leg-major, (leg, coordinate, sample), so that numpy's loops run
along the samples; the dot products are summed by `np.einsum` on row-major (sample, leg,
coordinate) copies, a fixed layout (einsum's order of summation follows the layout), so every
number is the same to the bit whatever the layout of the work.

The motor checks of the trajectory generator (`segment_peaks`): every segment it plans is
checked at a few hundred samples, each sample's motor angles, speeds and torques
(`planner.motion.dynamics`), of which each segment keeps its peaks. All the samples of several
segments go through numpy together; every number is computed per sample with the operations
the single-segment functions use, so each segment's peaks are those it has alone, to the bit.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np

from planner.motion.dynamics import LumpedDynamics
from planner.motion.kinematics import (
    DeltaGeometry,
    angles_and_reachability,
    inverse_kinematics,
    row_sums,
)

_Z = np.array([0.0, 0.0, 1.0])
_EYE = np.eye(3)[None]


class MotorRates(NamedTuple):
    """Motor state along a sampled TCP motion, each (n, 3) [rad, rad/s, rad/s^2]; `jac` is
    dp/dq (n, 3, 3) [m/rad]."""

    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    jac: np.ndarray


class LegLoops(NamedTuple):
    """The leg loops at n TCP positions, each (n, 3, 3) (sample, leg, coordinate) and
    row-major [m, m/rad, m/rad^2], with the motor angles' cosines (n, 3).

    Attributes:
        rho: Elbow to platform joint point, per leg.
        d_elbow: dE/dq, the elbow's motion per radian of its motor.
        dd_elbow: d2E/dq2.
        cos_q: cos of the motor angles.
        b: rho . dE/dq per leg (n, 3) [m^2/rad].
    """

    rho: np.ndarray
    d_elbow: np.ndarray
    dd_elbow: np.ndarray
    cos_q: np.ndarray
    b: np.ndarray


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
    loops = leg_loops(geom, q, xyz)
    qdot, qddot = speeds_and_accelerations(loops, v, a)
    jac = np.linalg.solve(loops.rho, loops.b[:, :, None] * _EYE)
    return MotorRates(q, qdot, qddot, jac)


def leg_loops(geom: DeltaGeometry, q, xyz: np.ndarray) -> LegLoops:
    """The leg loops of the TCP positions `xyz` (n, 3) [m] at motor angles `q` (n, 3) [rad]."""
    u = geom.radial[:, :, None]  # (leg, coordinate, 1)
    z = _Z[None, :, None]
    ua = geom.upper_arm
    platform = np.ascontiguousarray(xyz.T) + np.array([[0.0], [0.0], [geom.tcp_offset]])
    q_t = np.ascontiguousarray(np.asarray(q, dtype=float).T)
    cq, sq = np.cos(q_t)[:, None, :], np.sin(q_t)[:, None, :]  # (leg, 1, n)
    # Each product once: (-s) u is -(s u) to the bit (a product's sign is its factors').
    cu, su, cz, sz = cq * u, sq * u, cq * z, sq * z
    # `planner.motion.kinematics.elbows_from_cos_sin`, term by term.
    elbows = (geom.base_centre + geom.base_radius * geom.radial)[:, :, None] + ua * (cu - sz)
    rho = row_major(platform[None, :, :] + geom.platform_radius * u - elbows)
    d_elbow = row_major(ua * (-su - cz))  # dE/dq = ua (-s u - c z)
    dd_elbow = row_major(ua * (-cu + sz))  # d2E/dq2 = ua (-c u + s z)
    b = np.einsum("nij,nij->ni", rho, d_elbow)
    return LegLoops(rho, d_elbow, dd_elbow, cq[:, 0, :].T, b)


def speeds_and_accelerations(loops: LegLoops, v: np.ndarray, a: np.ndarray):
    """Motor speeds and accelerations (n, 3) [rad/s, rad/s^2] of TCP velocities `v` and
    accelerations `a` (n, 3) [m/s, m/s^2] through the leg loops."""
    rho, d_elbow, b = loops.rho, loops.d_elbow, loops.b
    qdot = np.einsum("nij,nj->ni", rho, v) / b
    # v - dE/dq qd per leg, leg-major: (leg, coordinate, n).
    rel = v.T[None, :, :] - d_elbow.transpose(1, 2, 0) * qdot.T[:, None, :]
    num = row_sums(rel * rel) + np.einsum("nij,nj->ni", rho, a)
    num -= np.einsum("nij,nij->ni", rho, loops.dd_elbow) * qdot**2
    return qdot, num / b


def row_major(legs: np.ndarray) -> np.ndarray:
    """A leg-major (leg, coordinate, n) array as a row-major (n, leg, coordinate) copy."""
    return np.ascontiguousarray(legs.transpose(2, 0, 1))


def segment_peaks(
    geom: DeltaGeometry,
    dynamics: LumpedDynamics | None,
    pos: np.ndarray,
    vel: np.ndarray,
    acc: np.ndarray,
    sizes: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per segment of samples stacked segment after segment (`sizes` (S,) rows each): whether
    every sample is inside the workspace, and for the segments inside, their peak motor speed
    [rad/s] and peak motor torque [N m] (0 without dynamics).

    Args:
        pos: TCP positions (N, 3) [m].
        vel: TCP velocities (N, 3) [m/s].
        acc: TCP accelerations (N, 3) [m/s^2].
        sizes: Samples per segment (S,), each >= 1.

    Returns:
        (inside (S,) bool, speed peaks, torque peaks), the peaks one per segment inside.
    """
    q, reachable = angles_and_reachability(geom, pos)
    inside = np.logical_and.reduceat(reachable, firsts(sizes))
    if not inside.all():  # the motor rates of the segments inside only
        rows = np.repeat(inside, sizes)
        q, pos, vel, acc = (x.compress(rows, axis=0) for x in (q, pos, vel, acc))
        sizes = sizes[inside]
        if not sizes.size:
            return inside, np.zeros(0), np.zeros(0)
    starts = firsts(sizes)
    loops = leg_loops(geom, q, pos)
    qdot, qddot = speeds_and_accelerations(loops, vel, acc)
    speeds = peaks(qdot, starts)
    if dynamics is None:
        return inside, speeds, np.zeros_like(speeds)
    arms, force = dynamics.arms_and_force(loops.cos_q, qdot, qddot, acc)
    jac = np.linalg.solve(loops.rho, loops.b[:, :, None] * _EYE)  # as `motor_rates` solves it
    return inside, speeds, peaks(arms + np.einsum("nji,nj->ni", jac, force), starts)


def firsts(sizes) -> list[int]:
    """Index of each segment's first sample in samples stacked segment after segment."""
    return [0, *itertools.accumulate(sizes[:-1].tolist())]


def peaks(values: np.ndarray, starts: list[int]) -> np.ndarray:
    """Per segment, the largest magnitude in its rows of `values` (n, 3), the segments' rows
    stacked from `starts` (`firsts`) on, each segment's at least one: `np.max(np.abs(...))` of
    its rows (a maximum is exact in any order; a nan anywhere in a segment is its peak, as
    there)."""
    return np.maximum.reduceat(np.abs(values).ravel(), [3 * s for s in starts])
