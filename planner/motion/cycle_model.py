"""A fast cycle-time model for the decision managers, calibrated against the ruckig planner.

The decision managers ask for pick and place times dozens of times per decision, far too often
to plan ruckig chains. Each move is instead timed per axis with the closed-form duration of a
rest-to-rest jerk-limited (7-phase) profile under the same limits, the slowest axis decides
(as ruckig's time synchronisation does), and an affine calibration `c0 + c1 t` fitted to planned
chains absorbs what the closed form ignores (blended corners, the 25 mm approach and lift, the
belt velocity at contact). `CycleTimeModel.fit` recomputes the calibration from ruckig plans;
`tests/test_cycle_model.py` reports its errors on fresh random moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.errors import PlannerInputError
from planner.motion.limits import MotionLimits, limits_for_payload


def jerk_limited_time(d: float, v: float, a: float, j: float) -> float:
    """Shortest rest-to-rest time [s] over distance `d` [m] with speed, acceleration and jerk
    limits `v`, `a`, `j` (closed form of the 7-phase profile)."""
    d = abs(d)
    if d == 0.0:
        return 0.0
    if v * j < a * a:  # the speed limit comes before full acceleration
        a = math.sqrt(v * j)
    if d >= v * (v / a + a / j):  # cruises at v
        return d / v + v / a + a / j
    r = a * a / j
    vp = 0.5 * (-r + math.sqrt(r * r + 4.0 * a * d))  # peak speed with a constant-a phase
    if vp >= r:
        return 2.0 * (vp / a + a / j)
    return 4.0 * (d / (2.0 * j)) ** (1.0 / 3.0)  # jerk phases only


# Fitted by `planner.motion.cycle_calibration.fitted_model` to 250 ruckig picks and places (seed 1,
# payload 0.1 kg, the cell's bins, items across the belt at x1/x1.2/x1.5, default pick config);
# reproduce with `python benchmarks/bench_motion.py --fit`.
PICK_COEF = (0.0350, 1.0157)
PLACE_COEF = (0.0490, 1.0023)


@dataclass(frozen=True)
class CycleTimeModel:
    """Pick and place durations of the planner, in microseconds per call.

    Attributes:
        limits: The motion limits the robot moves with (payload up to 1 kg by default).
        pick_z: TCP height at contact [m].
        approach_height: Corner above the item before the descent [m] (as `PickPlaceConfig`).
        lift_height: Corner above the pick after the seal [m].
        seal_time: Vacuum at the pick [s].
        release_time: Vacuum at the bin [s].
        pick_coef: (c0 [s], c1) of the start-to-contact calibration.
        place_coef: (c0 [s], c1) of the contact-to-release-end calibration (seal, lift,
            transfer, release included in c0 and the closed form).
    """

    limits: MotionLimits = limits_for_payload(0.0)
    pick_z: float = 0.02
    approach_height: float = 0.025
    lift_height: float = 0.025
    seal_time: float = 0.035
    release_time: float = 0.035
    pick_coef: tuple[float, float] = PICK_COEF
    place_coef: tuple[float, float] = PLACE_COEF

    def __post_init__(self):
        for name in ("pick_coef", "place_coef"):
            c = getattr(self, name)
            if len(c) != 2 or not all(math.isfinite(x) for x in c) or c[1] <= 0.0:
                raise PlannerInputError(name, "(c0 [s], c1 > 0), finite", c)

    def _move(self, dx: float, dy: float, dz: float) -> float:
        lim = self.limits
        v, a, j = lim.tcp_velocity, lim.tcp_acceleration, lim.tcp_jerk
        return max(
            jerk_limited_time(dx, v, a, j),
            jerk_limited_time(dy, v, a, j),
            jerk_limited_time(dz, v, a, j),
        )

    def time_to_pick(self, start_xyz, item_xy, belt_speed: float) -> float:
        """Time from `start_xyz` (at rest) until the cup touches an item now at `item_xy` that
        rides the belt at `belt_speed` along +x [s] (the meeting time; the reachable window is
        the caller's to check at the meeting point x + belt_speed t)."""
        sx, sy, sz = float(start_xyz[0]), float(start_xyz[1]), float(start_xyz[2])
        x, y = float(item_xy[0]), float(item_xy[1])
        c0, c1 = self.pick_coef
        dz = abs(sz - self.pick_z - self.approach_height) + self.approach_height
        t = 0.0
        for _ in range(8):  # contraction: the belt is ~20 times slower than the cup
            t_new = c0 + c1 * self._move(x + belt_speed * t - sx, y - sy, dz)
            if abs(t_new - t) < 1e-6:
                return t_new
            t = t_new
        return t

    def time_to_place(self, pick_xyz, bin_xyz) -> float:
        """Time from touching the item at `pick_xyz` until the release over the bin at
        `bin_xyz` has ended (seal, lift, transfer, release) [s]."""
        dx = float(bin_xyz[0]) - float(pick_xyz[0])
        dy = float(bin_xyz[1]) - float(pick_xyz[1])
        top = float(pick_xyz[2]) + self.lift_height
        dz = self.lift_height + abs(float(bin_xyz[2]) - top)
        c0, c1 = self.place_coef
        return self.seal_time + self.release_time + c0 + c1 * self._move(dx, dy, dz)

    def cycle_time(self, start_xyz, item_xy, belt_speed: float, bin_xyz) -> float:
        """Start to the end of the release over the bin, for one item [s]."""
        t = self.time_to_pick(start_xyz, item_xy, belt_speed)
        meet = (float(item_xy[0]) + belt_speed * t, float(item_xy[1]), self.pick_z)
        return t + self.time_to_place(meet, bin_xyz)

    def pick_raw(self, start_xyz, meet_xyz) -> float:
        """Uncalibrated closed-form time to a known meeting point [s] (for fitting)."""
        dz = abs(start_xyz[2] - meet_xyz[2] - self.approach_height) + self.approach_height
        return self._move(meet_xyz[0] - start_xyz[0], meet_xyz[1] - start_xyz[1], dz)

    def place_raw(self, pick_xyz, bin_xyz) -> float:
        """Uncalibrated closed-form transfer time [s] (for fitting)."""
        top = pick_xyz[2] + self.lift_height
        dz = self.lift_height + abs(bin_xyz[2] - top)
        return self._move(bin_xyz[0] - pick_xyz[0], bin_xyz[1] - pick_xyz[1], dz)


def fit_affine(raw: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    """Least-squares (c0, c1) with target ~ c0 + c1 raw."""
    design = np.stack([np.ones_like(raw), raw], axis=1)
    (c0, c1), *_ = np.linalg.lstsq(design, target, rcond=None)
    return float(c0), float(c1)
