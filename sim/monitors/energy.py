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

from sim.errors import CallOrderError, InvalidInput

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


class ActuatorLog:
    """The cell's actuator forces and speeds (and its trees' sleep) after each physics step,
    buffered for the energy meters that read them.

    A line of four robots meters four robots every millisecond: one `record` a step copies the
    whole model's `actuator_force` and `actuator_velocity` rows (two copies, however many
    robots) and every meter works out its robot's powers from the buffer in numpy when a figure
    is read or the buffer is full (`BUFFER_ROWS`).
    """

    BUFFER_ROWS = 512
    """Steps buffered before the meters integrate them."""

    def __init__(self, data: mujoco.MjData):
        self.data = data
        # The arrays read every step, bound once (an attribute of MjData makes a new view).
        self._force_now, self._speed_now = data.actuator_force, data.actuator_velocity
        self._asleep_now = data.tree_asleep
        n = self.BUFFER_ROWS
        self.force = np.empty((n, len(data.actuator_force)))
        self.speed = np.empty((n, len(data.actuator_velocity)))
        self.duration = np.empty(n)
        self.tree_asleep: np.ndarray | None = None  # (n, ntree) once a meter watches sleep
        self.rows = 0
        self.meters: list[EnergyMeter] = []

    def watch_sleep(self) -> None:
        """Record the trees' sleep too (a meter of a robot that may sleep reads it)."""
        if self.tree_asleep is None:
            if self.rows:
                raise CallOrderError("watch_sleep after steps were recorded")
            self.tree_asleep = np.empty((self.BUFFER_ROWS, len(self.data.tree_asleep)), np.int32)

    def record(self, duration_s: float) -> None:
        """Record the step (or block of idle steps) just made, which covered `duration_s` [s]."""
        k = self.rows
        self.force[k] = self._force_now
        self.speed[k] = self._speed_now
        if self.tree_asleep is not None:
            self.tree_asleep[k] = self._asleep_now
        self.duration[k] = duration_s
        self.rows = k + 1
        if self.rows == self.BUFFER_ROWS:
            for meter in self.meters:
                meter._integrate()
            self.rows = 0
            for meter in self.meters:
                meter._done = 0


class EnergyMeter:
    """Integrates one robot's motors' mechanical and electrical energy as the physics steps.

    The power of a step is taken at the state it left (for a block of idle steps, the holding
    torque over the whole block; the motors then stand still and only the copper loss counts).
    Alone, the meter keeps its own `ActuatorLog`: call `add(duration)` after each `mj_step`
    with the simulated time it covered. The meters of a line share one log (`log`): call its
    `record(duration)` once a step instead.

    Figures are computed from the log in numpy when read, with the same operations in the same
    order as `power_w` does one step at a time, so every figure is the same to the bit
    (tests/test_energy.py).

    Args:
        model, data: The cell's model and data.
        drive: The drives' losses.
        prefix: Name prefix of the robot metered ("" for the robot's own names; "r1_" for
            robot `r1_` of a sorting line, `sim.model.line_model`).
        asleep_tree: A kinematic tree of the robot that sleeps when it does
            (`sim.cell.idle_sleep.IdleSleep.tree`), or None (it never does). Asleep, it is
            metered holding still with the torques it came to rest with (MuJoCo computes none
            for a sleeping body).
        log: The log shared with the cell's other meters (None: the meter's own).

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
        asleep_tree: int | None = None,
        log: ActuatorLog | None = None,
    ):
        self.data = data
        self.log = log if log is not None else ActuatorLog(data)
        self.log.meters.append(self)
        self._done = self.log.rows  # log rows already integrated
        self._asleep_tree = asleep_tree
        if asleep_tree is not None:
            self.log.watch_sleep()
        drive = drive or DriveModel()
        self._actuators = np.array([model.actuator(prefix + name).id for name in ACTUATORS])
        constants = [drive.arm_motor_constant] * 3 + [drive.axis4_motor_constant]
        self._inverse_km2 = (1.0 / np.square(constants)).tolist()
        self._efficiency = drive.efficiency
        self._last_velocity = data.actuator_velocity[self._actuators].tolist()
        self._last_force = data.actuator_force[self._actuators].copy()
        self._totals = [0.0, 0.0, 0.0]  # mechanical, electrical, signed [J]

    @property
    def mechanical_j(self) -> float:
        self._integrate()
        return self._totals[0]

    @property
    def electrical_j(self) -> float:
        self._integrate()
        return self._totals[1]

    @property
    def signed_j(self) -> float:
        self._integrate()
        return self._totals[2]

    def power_w(self) -> tuple[float, float, float]:
        """(mechanical, electrical, signed) power over the step just made [W]: the actuators'
        forces of that step (computed at its start, held through it) times the joints' mean
        speed over it (before and after), which makes the signed work exact for MuJoCo's
        integrator (tests/test_energy.py closes the work-energy balance to 0.1 %)."""
        self._integrate()
        tau = self.data.actuator_force[self._actuators].tolist()
        velocity = self.data.actuator_velocity[self._actuators].tolist()
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
        """Record the step (or block of idle steps) just made, over its `duration_s` [s], in
        the meter's log (a shared log is recorded once a step by its owner instead)."""
        self.log.record(duration_s)

    def reading(self) -> tuple[float, float]:
        """(mechanical, electrical) energy so far [J]."""
        self._integrate()
        return self._totals[0], self._totals[1]

    def _integrate(self) -> None:
        """The log's steps not yet counted: their powers (`power_w`'s operations, actuator by
        actuator in its order) added to the totals step by step (a cumulative sum adds in
        order)."""
        log, start = self.log, self._done
        n = log.rows - start
        if n <= 0:
            return
        rows = slice(start, log.rows)
        force = log.force[rows, self._actuators]
        speed = log.speed[rows, self._actuators]
        if self._asleep_tree is not None:
            assert log.tree_asleep is not None  # watched since this meter was made
            asleep = log.tree_asleep[rows, self._asleep_tree] >= 0
            if asleep.any():
                # Asleep, the motors hold the robot still with the torques they held it with
                # when it came to rest (row -1: the last row before these).
                last_awake = np.where(asleep, -1, np.arange(n))
                np.maximum.accumulate(last_awake, out=last_awake)
                force = np.concatenate([self._last_force[None], force])[last_awake + 1]
                speed[asleep] = 0.0
        before = np.empty_like(speed)
        before[0], before[1:] = self._last_velocity, speed[:-1]
        power = force * (0.5 * (speed + before))
        mechanical, driving, signed, copper = (np.zeros(n) for _ in range(4))
        for j, k in enumerate(self._inverse_km2):
            p, f = power[:, j], force[:, j]
            mechanical = mechanical + np.abs(p)
            driving = driving + np.where(p < 0.0, 0.0, p)
            signed = signed + p
            copper = copper + f * f * k
        electrical = driving / self._efficiency + copper
        duration = log.duration[rows]
        for i, rate in enumerate((mechanical, electrical, signed)):
            steps = np.empty(n + 1)
            steps[0], steps[1:] = self._totals[i], rate * duration
            self._totals[i] = float(np.cumsum(steps)[-1])
        self._last_velocity = speed[-1].tolist()
        self._last_force = force[-1].copy()
        self._done = log.rows
