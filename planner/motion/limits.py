"""Motion limits of the IRB 360-3/1130's TCP, axis 4 and motors, with the source of each.

Cartesian limits are per axis (a box, as ruckig enforces them): each of x, y and z obeys
`tcp_velocity`, `tcp_acceleration` and `tcp_jerk` on its own.

Sources:
- `tcp_velocity` 10 m/s and the 100 m/s^2 acceleration ceiling: ABB's IRB 360 data sheet (max
  TCP velocity 10 m/s, max TCP acceleration 100 m/s^2 for the 1130 variants).
- Payload dependence of the acceleration (the datasheet is silent): derived in the simulation so
  that the motor torques stay inside the model's `forcerange` with the payload on the cup while
  the TCP tracks within 1 mm (Cycle 1 run by `sortsim cycle --payload KG`; see
  `tests/test_cycle.py`). ABB's own ratings fall with payload the same way (150 cycles/min at
  1 kg, 115 at 3 kg), i.e. about (150/115)^2 = 1.7 times less acceleration at 3 kg for the
  same path. The 3 kg figure, 45 m/s^2, is the largest that keeps the Cycle 1 peak torque under
  95 % of the limit; between 1 and 3 kg we keep the product (c + m) a constant.
- `tcp_jerk` (the datasheet is silent): 15 ms to ramp to full acceleration at up to 1 kg, 20 ms
  at 3 kg; shorter ramps drive the motors into their torque limit on Cycle 1's blended corners
  (x and z accelerating together), longer ones waste time (tested in physics).
- Axis 4: 62.8 rad/s (3600 deg/s) is an assumed speed ceiling (we found no datasheet figure to
  cite; it never binds: Cycle 1 turns 90 deg with a peak near 10 rad/s). The acceleration,
  800 rad/s^2, is what the axis-4 servo's 3 N m `forcerange` gives with its reflected inertia
  (0.002 kg m^2) and a 3 kg, 60 mm payload (0.0018 kg m^2): 800 x 0.0038 = 3.0 N m; the jerk
  takes the same 20 ms ramp.
- `motor_velocity`: the motor speed needed to move the TCP at the datasheet's 10 m/s straight
  down at the centre of the working range at the pick height (z = 0.05 m: 24.2 rad/s for the
  model's geometry), rounded up to 25 rad/s, so that 10 m/s is reachable where ABB quotes it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from planner.errors import PlannerInputError

VACUUM_SEAL_S = 0.035
"""Vacuum build-up with the cup on the item, ABB's Cycle 1 figure [s] (the one home of it)."""
VACUUM_RELEASE_S = 0.035
"""Vacuum release over the bin, ABB's Cycle 1 figure [s]."""

MAX_PAYLOAD_KG = 3.0
"""Rated payload of the IRB 360-3/1130 [kg]."""

_ACCEL_AT_1KG = 100.0  # [m/s^2], datasheet ceiling, held at light payloads
_ACCEL_AT_3KG = 45.0  # [m/s^2], derived (torque limits with 3 kg on the cup)
_RAMP_AT_1KG = 0.015  # [s] from zero to full acceleration, i.e. jerk = acceleration / ramp
_RAMP_AT_3KG = 0.020  # [s]
# a(m) = K / (c + m) through (1 kg, 100) and (3 kg, 45): a constant effective force, since the
# torque goes with (moving mass + payload) x acceleration.
_C = (_ACCEL_AT_3KG * 3.0 - _ACCEL_AT_1KG) / (_ACCEL_AT_1KG - _ACCEL_AT_3KG)
_K = _ACCEL_AT_1KG * (_C + 1.0)


@dataclass(frozen=True)
class MotionLimits:
    """Kinematic limits used by the trajectory generator.

    Attributes:
        tcp_velocity: Per-axis TCP speed limit [m/s].
        tcp_acceleration: Per-axis TCP acceleration limit [m/s^2].
        tcp_jerk: Per-axis TCP jerk limit [m/s^3].
        axis4_velocity: Axis-4 speed limit [rad/s].
        axis4_acceleration: Axis-4 acceleration limit [rad/s^2].
        axis4_jerk: Axis-4 jerk limit [rad/s^3].
        motor_velocity: Speed limit of each of the three main motors [rad/s].
    """

    tcp_velocity: float = 10.0
    tcp_acceleration: float = _ACCEL_AT_1KG
    tcp_jerk: float = _ACCEL_AT_1KG / _RAMP_AT_1KG
    axis4_velocity: float = 62.8
    axis4_acceleration: float = 800.0
    axis4_jerk: float = 40000.0
    motor_velocity: float = 25.0

    def __post_init__(self):
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0.0):
                raise PlannerInputError(name, "a finite number > 0", value)

    @property
    def max_velocity(self) -> np.ndarray:
        """Ruckig's per-DoF velocity limits (x, y, z, axis4)."""
        v = self.tcp_velocity
        return np.array([v, v, v, self.axis4_velocity])

    @property
    def max_acceleration(self) -> np.ndarray:
        """Ruckig's per-DoF acceleration limits (x, y, z, axis4)."""
        a = self.tcp_acceleration
        return np.array([a, a, a, self.axis4_acceleration])

    @property
    def max_jerk(self) -> np.ndarray:
        """Ruckig's per-DoF jerk limits (x, y, z, axis4)."""
        j = self.tcp_jerk
        return np.array([j, j, j, self.axis4_jerk])

    @cached_property
    def ruckig_limits(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        """`max_velocity`, `max_acceleration` and `max_jerk` as tuples of 4 floats, as ruckig's
        input takes them (computed once)."""
        return (
            tuple(self.max_velocity.tolist()),
            tuple(self.max_acceleration.tolist()),
            tuple(self.max_jerk.tolist()),
        )

    def slowed(self, factor: float) -> MotionLimits:
        """Limits of the same motion played `factor` (> 1) times slower.

        Velocity scales by 1/factor, acceleration by 1/factor^2, jerk by 1/factor^3 (a time
        scaling), so a path that just met the motor-speed limit meets it with margin after.
        """
        if not (np.isfinite(factor) and factor >= 1.0):
            raise PlannerInputError("factor", "a finite number >= 1", factor)
        return replace(
            self,
            tcp_velocity=self.tcp_velocity / factor,
            tcp_acceleration=self.tcp_acceleration / factor**2,
            tcp_jerk=self.tcp_jerk / factor**3,
            axis4_velocity=self.axis4_velocity / factor,
            axis4_acceleration=self.axis4_acceleration / factor**2,
            axis4_jerk=self.axis4_jerk / factor**3,
        )


def limits_for_payload(payload_kg: float) -> MotionLimits:
    """The limits for a payload on the cup.

    Args:
        payload_kg: Payload mass [kg], 0 to 3.

    Returns:
        Datasheet limits with the acceleration held at 100 m/s^2 up to 1 kg and, above,
        a(m) = K / (c + m) through the derived 3 kg figure (constant effective force); the
        acceleration ramp time grows linearly from 15 ms at 1 kg to 20 ms at 3 kg.
    """
    if not (np.isfinite(payload_kg) and 0.0 <= payload_kg <= MAX_PAYLOAD_KG):
        raise PlannerInputError("payload_kg", f"0 to {MAX_PAYLOAD_KG} [kg]", payload_kg)
    m = max(1.0, float(payload_kg))
    accel = min(_ACCEL_AT_1KG, _K / (_C + m))
    ramp = _RAMP_AT_1KG + (m - 1.0) / (MAX_PAYLOAD_KG - 1.0) * (_RAMP_AT_3KG - _RAMP_AT_1KG)
    return replace(MotionLimits(), tcp_acceleration=accel, tcp_jerk=accel / ramp)
