"""Closed-form kinematics of the three-legged delta robot (ABB IRB 360 family).

Conventions (they match `models/abb_irb360/irb360.xml`): leg i has its motor axis at distance
`base_radius` from the base centre at azimuth `leg_azimuths[i]`, tangential to the base circle;
motor angle 0 puts the upper arm horizontal pointing outward, positive angles turn it downward.
The parallelogram forearm (two rods `rod_spacing` apart) keeps the platform parallel to the base,
so each leg reduces to one equivalent rod of length `forearm` between the elbow and a point
`platform_radius` out from the platform centre. Positions are world-frame TCP positions (the
`cup_site`, `tcp_offset` straight below the platform's joint plane). Williams, "The Delta Parallel
Robot: Kinematics Solutions" gives the same per-leg solution.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from planner.errors import PlannerInputError

_Z = np.array([0.0, 0.0, 1.0])


class Unreachable(PlannerInputError):
    """A TCP position outside the workspace: a leg has no solution or a motor is out of range."""


@dataclass(frozen=True)
class DeltaGeometry:
    """Dimensions of a delta robot [m, rad]; validated on construction.

    Attributes:
        base_radius: Base centre to each motor axis [m].
        upper_arm: Motor axis to elbow axis [m].
        forearm: Rod length, elbow joint to platform joint [m].
        platform_radius: Platform centre to the middle of each rod pair [m].
        rod_spacing: Distance between the two rods of one parallelogram [m].
        leg_azimuths: Azimuth of each leg about world z [rad], three values.
        base_height: World z of the motor axes' plane [m].
        tcp_offset: TCP (cup lip) distance below the platform joint plane [m].
        motor_lower: Lowest motor angle [rad].
        motor_upper: Highest motor angle [rad].
        base_xy: World x, y of the base centre [m].
    """

    base_radius: float = 0.200
    upper_arm: float = 0.350
    forearm: float = 0.800
    platform_radius: float = 0.060
    rod_spacing: float = 0.100
    leg_azimuths: tuple[float, float, float] = (0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0)
    base_height: float = 1.0
    tcp_offset: float = 0.10
    motor_lower: float = -0.8029
    motor_upper: float = 1.7453
    base_xy: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        for name in ("base_radius", "upper_arm", "forearm", "rod_spacing"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0.0):
                raise PlannerInputError(name, "a finite length > 0 [m]", value)
        for name in ("platform_radius", "tcp_offset"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0.0):
                raise PlannerInputError(name, "a finite length >= 0 [m]", value)
        if len(self.leg_azimuths) != 3 or not np.all(np.isfinite(self.leg_azimuths)):
            raise PlannerInputError("leg_azimuths", "three finite angles [rad]", self.leg_azimuths)
        if not np.isfinite(self.base_height):
            raise PlannerInputError("base_height", "a finite height [m]", self.base_height)
        if len(self.base_xy) != 2 or not np.all(np.isfinite(self.base_xy)):
            raise PlannerInputError("base_xy", "two finite coordinates [m]", self.base_xy)
        if not (-np.pi < self.motor_lower < self.motor_upper < np.pi):
            raise PlannerInputError(
                "motor_lower/motor_upper",
                "-pi < motor_lower < motor_upper < pi [rad]",
                (self.motor_lower, self.motor_upper),
            )

    @cached_property
    def radial(self) -> np.ndarray:
        """Outward unit vector of each leg, shape (3, 3) (read-only, computed once)."""
        a = np.asarray(self.leg_azimuths)
        return _read_only(np.stack([np.cos(a), np.sin(a), np.zeros(3)], axis=1))

    @cached_property
    def base_centre(self) -> np.ndarray:
        """World position of the base centre (motor plane) [m] (read-only, computed once)."""
        return _read_only(np.array([self.base_xy[0], self.base_xy[1], self.base_height]))


def _read_only(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


def _as_points(p) -> tuple[np.ndarray, bool]:
    arr = np.asarray(p, dtype=float)
    if arr.shape[-1:] != (3,) or arr.ndim > 2:
        raise PlannerInputError("p", "an array of shape (3,) or (n, 3) [m]", arr.shape)
    return np.atleast_2d(arr), arr.ndim == 1


def _leg_vectors(geom: DeltaGeometry, p: np.ndarray) -> np.ndarray:
    """Per leg, platform joint point minus motor axis point, leg-major: shape (3, 3, n) (leg,
    coordinate, position), so that numpy's loops run along the n positions."""
    tcp_up = np.array([[0.0], [0.0], [geom.tcp_offset]])
    # (coordinate, n), contiguous along n: numpy's loops run along the positions.
    platform = np.ascontiguousarray(p.T) + tcp_up - geom.base_centre[:, None]
    offsets = (geom.platform_radius - geom.base_radius) * geom.radial
    return platform[None, :, :] + offsets[:, :, None]


def row_sums(terms: np.ndarray) -> np.ndarray:
    """`np.sum(x, axis=-1)` of the (n, 3, 3) array x whose leg-major (3, 3, n) layout `terms`
    is (x[n, i, j] = terms[i, j, n]), as (n, 3): numpy adds the three terms of such a short
    last axis in order, ((x0 + x1) + x2), which is what is added here, row by row and far
    faster."""
    return ((terms[:, 0] + terms[:, 1]) + terms[:, 2]).T


def _ik_raw(geom: DeltaGeometry, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Motor angles (n, 3) with NaN where a leg has no solution, and the solvable mask."""
    legs = _leg_vectors(geom, p)
    d = np.ascontiguousarray(legs.transpose(2, 0, 1))  # (n, 3, 3): the layout einsum sums in
    a = np.einsum("nij,ij->ni", d, geom.radial)  # radial component
    c = d[..., 2]  # vertical component (negative below the base)
    k = (row_sums(legs * legs) + geom.upper_arm**2 - geom.forearm**2) / (2.0 * geom.upper_arm)
    # |rod|^2 = forearm^2 reduces to a cos(q) - c sin(q) = k, i.e. rho cos(q - alpha) = k with
    # rho = hypot(a, c) and alpha = atan2(-c, a): q = alpha +- acos(k / rho).
    rho = np.hypot(a, c)
    alpha = np.arctan2(-c, a)
    positive = rho > 0.0
    if positive.all():  # (a leg's radial and vertical components both 0: at its axis)
        ratio = k / rho
    else:
        ratio = np.divide(k, rho, out=np.full_like(k, np.inf), where=positive)
    ok = np.abs(ratio) <= 1.0
    beta = np.arccos(np.clip(ratio, -1.0, 1.0))
    q = alpha - beta  # elbow-out branch: the elbow lies outside the motor axis
    q = (q + np.pi) % (2.0 * np.pi) - np.pi
    return (q if ok.all() else np.where(ok, q, np.nan)), ok


def angles_and_reachability(geom: DeltaGeometry, p) -> tuple[np.ndarray, np.ndarray]:
    """Motor angles (n, 3) [rad] of TCP positions (n, 3) [m], NaN where a leg has no
    solution, and whether each position is reachable (n,): every leg has a solution with its
    motor within range (`reachable_mask`; the angles are `inverse_kinematics`' where it is)."""
    pts, _ = _as_points(p)
    q, ok = _ik_raw(geom, pts)
    legs = ok & (q >= geom.motor_lower) & (q <= geom.motor_upper)
    return q, legs[:, 0] & legs[:, 1] & legs[:, 2]  # np.all(legs, axis=-1), far cheaper


def reachable_mask(geom: DeltaGeometry, p) -> np.ndarray:
    """Vectorised reachability of TCP positions (n, 3) [m] -> bool (n,)."""
    return angles_and_reachability(geom, p)[1]


def is_reachable(geom: DeltaGeometry, p) -> bool:
    """True when every leg has a solution with its motor within range for TCP `p` [m]."""
    return bool(reachable_mask(geom, np.asarray(p, dtype=float).reshape(3))[0])


def inverse_kinematics(geom: DeltaGeometry, p) -> np.ndarray:
    """Motor angles [rad] for a TCP position [m]; vectorised over a leading axis.

    Args:
        p: World TCP position(s), shape (3,) or (n, 3) [m].

    Returns:
        Motor angles, shape (3,) or (n, 3) [rad].

    Raises:
        Unreachable: some position has a leg without solution or a motor out of range.
    """
    pts, single = _as_points(p)
    q, reachable = angles_and_reachability(geom, pts)
    bad = ~reachable
    if np.any(bad):
        first = pts[np.argmax(bad)]
        raise Unreachable("p", "a position inside the robot's workspace", tuple(first.round(4)))
    return q[0] if single else q


def elbows(geom: DeltaGeometry, q) -> np.ndarray:
    """World elbow points (middle of each rod pair's top axis) for motor angles (.., 3) [m]."""
    q = np.asarray(q, dtype=float)
    return elbows_from_cos_sin(geom, np.cos(q)[..., None], np.sin(q)[..., None])


def elbows_from_cos_sin(geom: DeltaGeometry, cos_q: np.ndarray, sin_q: np.ndarray) -> np.ndarray:
    """`elbows` from the cosines and sines of the motor angles, each (.., 3, 1), for callers
    that need those too [m]."""
    u = geom.radial
    return geom.base_centre + geom.base_radius * u + geom.upper_arm * (cos_q * u - sin_q * _Z)


def forward_kinematics(geom: DeltaGeometry, q) -> np.ndarray:
    """TCP position(s) [m] for motor angles (3,) or (n, 3) [rad] (three-sphere intersection).

    Raises:
        PlannerInputError: the spheres do not intersect (no assembly for these angles).
    """
    qa = np.asarray(q, dtype=float)
    single = qa.ndim == 1
    if qa.shape[-1:] != (3,) or qa.ndim > 2:
        raise PlannerInputError("q", "an array of shape (3,) or (n, 3) [rad]", qa.shape)
    qa = np.atleast_2d(qa)
    centres = elbows(geom, qa) - geom.platform_radius * geom.radial  # (n, 3, 3)
    c1, c2, c3 = centres[:, 0], centres[:, 1], centres[:, 2]
    ex = c2 - c1
    d = np.linalg.norm(ex, axis=-1, keepdims=True)
    ex = ex / d
    i = np.sum(ex * (c3 - c1), axis=-1, keepdims=True)
    ey = c3 - c1 - i * ex
    ey = ey / np.linalg.norm(ey, axis=-1, keepdims=True)
    ez = np.cross(ex, ey)
    j = np.sum(ey * (c3 - c1), axis=-1, keepdims=True)
    r2 = geom.forearm**2
    x = d / 2.0  # equal radii
    y = (i * i + j * j) / (2.0 * j) - (i / j) * x
    h2 = r2 - x * x - y * y
    if np.any(h2 < 0.0):
        raise PlannerInputError("q", "motor angles for which the robot can assemble", qa.tolist())
    # The two solutions are +/- ez; the platform hangs below the elbows.
    ez = np.where(ez[:, 2:3] > 0.0, -ez, ez)
    platform = c1 + x * ex + y * ey + np.sqrt(h2) * ez
    tcp = platform - np.array([0.0, 0.0, geom.tcp_offset])
    return tcp[0] if single else tcp


def jacobian(geom: DeltaGeometry, q) -> np.ndarray:
    """dp/dq of the TCP [m/rad] at motor angles q (3,) or (n, 3); shape (3, 3) or (n, 3, 3)."""
    qa = np.asarray(q, dtype=float)
    single = qa.ndim == 1
    qa = np.atleast_2d(qa)
    p = np.atleast_2d(forward_kinematics(geom, qa))
    platform = p + np.array([0.0, 0.0, geom.tcp_offset])
    u = geom.radial
    rods = platform[:, None, :] + geom.platform_radius * u - elbows(geom, qa)  # (n, 3, 3)
    cq, sq = np.cos(qa)[..., None], np.sin(qa)[..., None]
    z = np.array([0.0, 0.0, 1.0])
    delbow = geom.upper_arm * (-sq * u - cq * z)  # d elbow / d q_i, (n, 3, 3)
    # Loop equations |rod_i|^2 = l^2: rods @ dp = diag(rod_i . delbow_i) dq.
    b = np.einsum("nij,nij->ni", rods, delbow)
    jac = np.linalg.solve(rods, b[:, :, None] * np.eye(3)[None])
    return jac[0] if single else jac
