"""The robot's motor energy, integrated from the physics' torques and speeds.

Two figures, both per pick and per episode:

- mechanical: the integral of sum_i |tau_i omega_i| over the robot's four actuated joints (the
  three arm motors and axis 4), tau the actuator's force on its joint (`data.actuator_force`,
  gear 1) and omega the joint's speed. It counts braking work as well as driving work: what
  the arms' motors do, whichever way the power flows.
- electrical, regenerative-free: the power the drives draw from the mains when the braking
  energy is burnt in a brake resistor rather than fed back (as on a drive without an active
  front end): for each joint, max(tau omega, 0) / `DriveModel.efficiency` (driving power
  through the gearbox and the drive) plus the copper loss (tau / K_m)^2 (the torque-making
  current's heat, paid also when holding still against gravity), K_m the motor constant
  referred to the joint. Idle electronics, the brakes and the vacuum generator are not counted.

The drive's figures are estimates (ABB publishes none for the IRB 360): a 1.5-2 kW servo motor
of 2.6 N m rated torque behind a gearbox of ratio 15 at 94 % (models/abb_irb360/README.md,
"Motors"); such a motor has a motor constant of about 0.21 N m/sqrt(W) (150 W of copper loss at
rated torque), 0.21 x 15 x 0.94 = 3.0 N m/sqrt(W) at the arm; gearbox 0.94 x drive 0.97 = 0.91
for driving power. Axis 4's small servo: 0.3 N m/sqrt(W) at its joint.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from sim.errors import InvalidInput

JOULES_PER_KWH = 3.6e6


@dataclass(frozen=True)
class DriveModel:
    """Losses of the robot's drives, for the regenerative-free electrical estimate.

    Attributes:
        efficiency: Share of the drawn driving power that reaches the joint (gearbox x drive).
        arm_motor_constant: Motor constant of an arm motor referred to its joint [N m/sqrt(W)].
        axis4_motor_constant: The same for axis 4 [N m/sqrt(W)].
    """

    efficiency: float = 0.91
    arm_motor_constant: float = 3.0
    axis4_motor_constant: float = 0.3

    def __post_init__(self):
        if not (math.isfinite(self.efficiency) and 0.0 < self.efficiency <= 1.0):
            raise InvalidInput("efficiency", "a share in (0, 1]", self.efficiency)
        for name in ("arm_motor_constant", "axis4_motor_constant"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInput(name, "a motor constant > 0 [N m/sqrt(W)]", value)


ACTUATORS = ("motor_1", "motor_2", "motor_3", "axis4")
"""The robot's actuated joints' actuators, by name in the MJCF."""


class EnergyMeter:
    """Integrates the motors' mechanical and electrical energy as the physics steps.

    Call `add(duration)` after each `mj_step` with the simulated time it covered: the power is
    taken at the state the step left (for a block of idle steps, the holding torque over the
    whole block; the motors then stand still and only the copper loss counts).

    Args:
        model, data: The cell's model and data.
        drive: The drives' losses.
        prefix: Name prefix of the robot metered ("" for the robot's own names; "r1_" for
            robot `r1_` of a sorting line, `sim.cell.line_model`).

    Attributes:
        mechanical_j: Integral of sum |tau omega| so far [J].
        electrical_j: Regenerative-free electrical energy so far [J].
        signed_j: Net work of the motors so far, driving minus braking [J].
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        drive: DriveModel | None = None,
        *,
        prefix: str = "",
    ):
        self.data = data
        drive = drive or DriveModel()
        ids = [model.actuator(prefix + name).id for name in ACTUATORS]
        self._actuators = np.array(ids)
        constants = [drive.arm_motor_constant] * 3 + [drive.axis4_motor_constant]
        self._inverse_km2 = (1.0 / np.square(constants)).tolist()
        self._efficiency = drive.efficiency
        # Views of the actuators' forces and speeds in `data` (one slice when the actuators are
        # consecutive, as in the cell), read as Python floats each step: four numbers do not
        # pay numpy's per-call cost.
        first = int(self._actuators[0])
        if np.array_equal(self._actuators, np.arange(first, first + len(ids))):
            span = slice(first, first + len(ids))
            force, speed = data.actuator_force[span], data.actuator_velocity[span]
            self._read = lambda: (force.tolist(), speed.tolist())
        else:
            ids = self._actuators
            self._read = lambda: (
                data.actuator_force[ids].tolist(),
                data.actuator_velocity[ids].tolist(),
            )
        self._last_velocity = self._read()[1]
        self.mechanical_j = 0.0
        self.electrical_j = 0.0
        self.signed_j = 0.0

    def power_w(self) -> tuple[float, float, float]:
        """(mechanical, electrical, signed) power over the step just made [W]: the actuators'
        forces of that step (computed at its start, held through it) times the joints' mean
        speed over it (before and after), which makes the signed work exact for MuJoCo's
        integrator (tests/test_energy.py closes the work-energy balance to 0.1 %)."""
        tau, velocity = self._read()
        mechanical = driving = signed = copper = 0.0
        for f, v, v0, k in zip(tau, velocity, self._last_velocity, self._inverse_km2, strict=True):
            power = f * (0.5 * (v + v0))
            mechanical += abs(power)
            driving += 0.0 if power < 0.0 else power  # max(power, 0.0), without the call
            signed += power
            copper += f * f * k
        self._last_velocity = velocity
        return mechanical, driving / self._efficiency + copper, signed

    def add(self, duration_s: float) -> None:
        """Add the power of the step (or block of idle steps) just made, over its
        `duration_s` [s]."""
        mechanical, electrical, signed = self.power_w()
        self.mechanical_j += mechanical * duration_s
        self.electrical_j += electrical * duration_s
        self.signed_j += signed * duration_s

    def reading(self) -> tuple[float, float]:
        """(mechanical, electrical) energy so far [J]."""
        return self.mechanical_j, self.electrical_j
