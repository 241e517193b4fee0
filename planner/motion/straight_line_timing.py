"""A physically derived stand-in cycle-time model: straight-line moves at the robot's limits.

Each move is a straight line travelled with a trapezoidal speed profile (rest to rest, maximum
speed `v_max`, acceleration `a_max`); 35 ms of vacuum are added at the pick and at the place
(ABB's Cycle 1 convention). It has no jerk limit, no corner blending and no per-axis
synchronisation; it serves tests that need a model independent of the motion planner. The
episode runner and the decision benchmark use `planner.motion.cycle_model.CycleTimeModel`, fitted to
the ruckig trajectories.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from planner.errors import PlannerInputError
from planner.motion.limits import VACUUM_SEAL_S


def trapezoid_time(distance: float, v_max: float, a_max: float) -> float:
    """Duration of a rest-to-rest straight move of `distance` [m] at limits v_max, a_max [s]."""
    if distance <= 0.0:
        return 0.0
    if distance <= v_max * v_max / a_max:
        return 2.0 * math.sqrt(distance / a_max)
    return distance / v_max + v_max / a_max


@dataclass(frozen=True)
class StraightLineCycleModel:
    """Cycle times from straight rest-to-rest moves; implements CycleTimeEstimator.

    Attributes:
        v_max: TCP speed limit [m/s] (IRB 360 datasheet: 10 m/s).
        a_max: TCP acceleration limit [m/s^2].
        vacuum_s: Seal and release time at the pick and at the place [s].
        pick_z: TCP height when it meets an item [m].
        lift: Vertical descent onto the item and lift-off from it [m].
    """

    v_max: float = 10.0
    a_max: float = 50.0
    vacuum_s: float = VACUUM_SEAL_S
    pick_z: float = 0.02
    lift: float = 0.025

    def __post_init__(self):
        for name in ("v_max", "a_max"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise PlannerInputError(name, "a finite limit > 0", value)
        for name in ("vacuum_s", "lift"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise PlannerInputError(name, "a finite value >= 0", value)

    def move_time(self, distance: float) -> float:
        """Duration of a straight move of `distance` [m] plus the vertical approach [s]."""
        return trapezoid_time(distance + self.lift, self.v_max, self.a_max)

    def time_to_pick(self, start_xyz, item_xy, belt_speed: float) -> float:
        """Time until the cup has sealed on an item now at `item_xy`, moving at `belt_speed` [s].

        Solves t = move_time(|start - item(t)|) + vacuum by fixed-point iteration (a contraction
        because the belt is far slower than the robot).
        """
        sx, sy, sz = (float(c) for c in start_xyz)
        x, y = float(item_xy[0]), float(item_xy[1])
        dz2 = (sz - self.pick_z) ** 2
        t = 0.0
        for _ in range(60):
            dx = x + belt_speed * t - sx
            t_new = self.move_time(math.sqrt(dx * dx + (y - sy) ** 2 + dz2)) + self.vacuum_s
            if abs(t_new - t) < 1e-10:
                return t_new
            t = t_new
        return t

    def time_to_place(self, pick_xyz, bin_xyz) -> float:
        """Time from the pick point until the item is released over the bin [s]."""
        d = math.dist(tuple(map(float, pick_xyz)), tuple(map(float, bin_xyz)))
        return self.move_time(d) + self.vacuum_s

    def cycle_time(self, start_xyz, item_xy, belt_speed: float, bin_xyz) -> float:
        """Pick then place of one item [s] (the meeting point is where the item is met)."""
        t_pick = self.time_to_pick(start_xyz, item_xy, belt_speed)
        meet = (float(item_xy[0]) + belt_speed * t_pick, float(item_xy[1]), self.pick_z)
        return t_pick + self.time_to_place(meet, bin_xyz)
