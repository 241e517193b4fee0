"""Plays a planned TCP trajectory on the simulated robot and records how well it is followed.

The trajectory is sampled at the control period, mapped through the analytic inverse kinematics
to motor set-points (with the reference motor speeds as velocity feed-forward, so the position
servos act as PD controllers around a moving reference), and the physics is stepped. Records the
TCP tracking error, the motors' torques (`actuator_force`) against their `forcerange`, and the
platform's tilt. The planner's trajectory objects are only read (`at_time`, `duration`).

`lumped_dynamics` and `TrajectoryExecutor` take a keyword `prefix` (default "": the robot's own
names): the name prefix of one robot of a sorting line (`sim.model.line_model`), which they then
read and drive, leaving the other robots' actuators alone.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import mujoco
import numpy as np

from planner.motion.dynamics import GRAVITY, LumpedDynamics
from planner.motion.kinematics import DeltaGeometry
from planner.motion.motor_rates import motor_rates
from sim.cell.robot import (
    MOTOR_ACTUATORS,
    geometry_from_model,
)
from sim.errors import InvalidInput


class Playable(Protocol):
    """What the executor needs of a trajectory (a `planner.motion.trajectory.Chain` or
    `Segment`)."""

    @property
    def duration(self) -> float: ...

    def at_time(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def states_at(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class ExecutionLog:
    """What happened while a trajectory was played (one row per control period).

    Attributes:
        time: Time since the trajectory's start [s].
        planned: Planned (x, y, z [m], axis4 [rad]) at each time.
        actual: Simulated TCP (cup_site) position and axis-4 angle at each time.
        motor_torque: Motor actuator forces [N m], shape (N, 3).
        torque_limit: The motors' force range upper bounds [N m], shape (3,).
        tilt: Platform tilt from level [rad].
    """

    time: np.ndarray
    planned: np.ndarray
    actual: np.ndarray
    motor_torque: np.ndarray
    torque_limit: np.ndarray
    tilt: np.ndarray

    @property
    def tracking_error(self) -> np.ndarray:
        """Distance between the planned and simulated TCP positions [m], shape (N,)."""
        return np.linalg.norm(self.actual[:, :3] - self.planned[:, :3], axis=1)

    def error_at(self, t: float) -> float:
        """Tracking error [m] at the logged time nearest to `t` [s]."""
        return float(self.tracking_error[int(np.argmin(np.abs(self.time - t)))])

    @property
    def peak_torque(self) -> np.ndarray:
        """Largest absolute torque of each motor [N m], shape (3,)."""
        return np.max(np.abs(self.motor_torque), axis=0)

    @property
    def peak_torque_ratio(self) -> float:
        """Largest |torque| / limit over the motors and the run (1 = saturated)."""
        return float(np.max(self.peak_torque / self.torque_limit))


def lumped_dynamics(
    model: mujoco.MjModel, geometry: DeltaGeometry, payload_kg: float = 0.0, *, prefix: str = ""
) -> LumpedDynamics:
    """The delta's lumped-mass model with every figure read from the compiled MJCF.

    Upper arm inertia about the motor axis (principal inertia turned onto the axis, plus the
    parallel-axis term, plus the motor's reflected `armature`), half of the two rods at the elbow,
    the other halves with everything under the platform (cup, any payload body), the motor joint
    damping and the motors' `forcerange`. `payload_kg` adds a held load that is not part of
    the robot's kinematic tree (an item welded to the cup) [kg]. `prefix` names the robot.
    """
    p = prefix
    arm = model.body(f"{p}upper_arm_1_link")
    joint = model.joint(f"{p}motor_1_joint")
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, arm.iquat)
    axis = rot.reshape(3, 3).T @ joint.axis  # motor axis in the principal frame
    com = arm.ipos - joint.pos
    off_axis = com - np.dot(com, joint.axis) * joint.axis
    rod_mass = float(sum(model.body(f"{p}rod_1{r}_link").mass[0] for r in ("a", "b")))
    la = geometry.upper_arm
    inertia = float(np.dot(arm.inertia, axis**2) + arm.mass[0] * off_axis @ off_axis)
    inertia += float(model.dof_armature[joint.dofadr[0]]) + 0.5 * rod_mass * la**2
    platform = model.body(f"{p}platform_link").id
    limit = min(model.actuator_forcerange[model.actuator(p + n).id, 1] for n in MOTOR_ACTUATORS)
    return LumpedDynamics(
        arm_inertia=inertia,
        arm_moment=float(arm.mass[0] * np.linalg.norm(off_axis) + 0.5 * rod_mass * la),
        damping=float(model.dof_damping[joint.dofadr[0]]),
        moving_mass=float(model.body_subtreemass[platform]) + 3 * 0.5 * rod_mass + payload_kg,
        torque_limit=float(limit),
    )


class TrajectoryExecutor:
    """Executes trajectories on the robot of `model`/`data` (both owned by the caller).

    Args:
        model: Compiled model containing the IRB 360.
        data: Its data; the robot is expected at the trajectory's start state.
        control_dt: Control period [s], a whole multiple of the physics time step; default one
            time step.
        geometry: Robot geometry; read from the model when omitted.
        feedforward: Add the lumped-model torque to the servo set-points (as `tau / kp`).
        payload_kg: Load held by the cup outside the robot's tree, for the feed-forward [kg];
            change it with `set_payload` as items are picked and released.
        prefix: Name prefix of the robot in `model` ("" for the robot's own names).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        control_dt: float | None = None,
        geometry: DeltaGeometry | None = None,
        feedforward: bool = True,
        payload_kg: float = 0.0,
        *,
        prefix: str = "",
    ):
        self.feedforward = feedforward
        self.prefix = p = prefix
        step = model.opt.timestep
        control_dt = step if control_dt is None else control_dt
        substeps = int(round(control_dt / step))
        if substeps < 1 or abs(substeps * step - control_dt) > 1e-9:
            raise InvalidInput(
                "control_dt", f"a whole multiple of the time step {step} s", control_dt
            )
        self.model, self.data = model, data
        self.substeps = substeps
        self.control_dt = substeps * step
        self.geometry = geometry or geometry_from_model(model, prefix=p)
        self.dynamics = lumped_dynamics(model, self.geometry, prefix=p)
        self.payload_kg = 0.0
        self.set_payload(payload_kg)
        self._kp = np.array([model.actuator_gainprm[i, 0] for i in self._motor_ids_of(model, p)])
        self._motor_ids = [model.actuator(p + n).id for n in MOTOR_ACTUATORS]
        self._limits = np.array([model.actuator_forcerange[i, 1] for i in self._motor_ids])
        axis4 = model.joint(f"{p}axis4_joint")
        self._axis4_qpos = axis4.qposadr[0]
        # Axis 4 turns the cup (and any held item, neglected) about z: inertia, damping, gain.
        self._axis4_inertia = float(
            model.dof_armature[axis4.dofadr[0]] + model.body(f"{p}cup_link").inertia[2]
        )
        self._axis4_damping = float(model.dof_damping[axis4.dofadr[0]])
        self._axis4_kp = float(model.actuator(f"{p}axis4").gainprm[0])
        # Servo commands written in one go: the same law as `sim.cell.robot.set_motor_targets`
        # (set-point led by kv/kp x reference speed), without its per-call name lookups.
        self._act_ids = np.array(self._motor_ids + [model.actuator(f"{p}axis4").id])
        gains = model.actuator_gainprm[self._act_ids, 0]
        self._lead = -model.actuator_biasprm[self._act_ids, 2] / gains
        self._ctrl_lo = model.actuator_ctrlrange[self._act_ids, 0]
        self._ctrl_hi = model.actuator_ctrlrange[self._act_ids, 1]
        # Where the commands go in `data.ctrl`: one slice when the actuators are consecutive.
        first = int(self._act_ids[0])
        consecutive = np.array_equal(self._act_ids, np.arange(first, first + len(self._act_ids)))
        self._ctrl = self.data.ctrl
        self._ctrl_index = (
            slice(first, first + len(self._act_ids)) if consecutive else self._act_ids
        )
        self._site = model.site(f"{p}cup_site").id
        self._platform = model.body(f"{p}platform_link").id

    def set_payload(self, payload_kg: float) -> None:
        """Load now held by the cup outside the robot's tree [kg] (feed-forward only); may be
        called from `on_step` (e.g. when an item is sealed or released) and applies from the
        next control period."""
        if not (np.isfinite(payload_kg) and payload_kg >= 0.0):
            raise InvalidInput("payload_kg", "a finite mass >= 0 [kg]", payload_kg)
        self.payload_kg = float(payload_kg)

    @staticmethod
    def _motor_ids_of(model, prefix: str = ""):
        return [model.actuator(prefix + n).id for n in MOTOR_ACTUATORS]

    def references(self, trajectory: Playable, times: np.ndarray):
        """Planned states, motor set-points and feed-forward torques at `times` [s].

        Returns:
            pos (n, 4), vel (n, 4), acc (n, 4), q (n, 3), qdot (n, 3), torque of the robot
            without payload (n, 3), and torque per kilogram of payload (n, 3)
            [m, rad, s, N m, N m/kg].
        """
        pos, vel, acc = trajectory.states_at(times)
        q, qdot, qddot, jac = motor_rates(self.geometry, pos[:, :3], vel[:, :3], acc[:, :3])
        torque = self.dynamics.torque(q, qdot, qddot, jac, acc[:, :3])
        lift = acc[:, :3] + np.array([0.0, 0.0, GRAVITY])
        per_kg = np.einsum("nji,nj->ni", jac, lift)  # J^T (a + g): the payload's share
        return pos, vel, acc, q, qdot, torque, per_kg

    def playback(self, trajectory: Playable, hold: float = 0.0) -> Playback:
        """The servo set-points of `trajectory` (then `hold` seconds at its end), precomputed
        for every control period; whoever steps the physics applies them one period at a time.

        Args:
            trajectory: The plan (read only).
            hold: Extra time at the final set-point [s].
        """
        n = int(np.ceil((trajectory.duration + hold) / self.control_dt - 1e-9))
        times = (np.arange(n) + 1) * self.control_dt
        pos, vel, acc, q, qdot, tau, per_kg = self.references(trajectory, times)
        ff = 1.0 if self.feedforward else 0.0
        tau4 = self._axis4_inertia * acc[:, 3] + self._axis4_damping * vel[:, 3]
        axis4_cmd = pos[:, 3] + ff * tau4 / self._axis4_kp
        # Servo set-points [q1, q2, q3, axis4] and reference speeds, one row per period.
        base = np.c_[q + ff * tau / self._kp, axis4_cmd] + self._lead * np.c_[qdot, vel[:, 3]]
        shift = np.c_[ff * per_kg / self._kp, np.zeros(n)]  # per kg of payload
        return Playback(self, times, pos, base, shift)

    def write_setpoint(self, command: np.ndarray) -> None:
        """Write one period's servo commands [rad] into `data.ctrl`, clipped to the ranges."""
        self.write_clipped(self.clip_setpoints(command))

    def clip_setpoints(self, commands: np.ndarray) -> np.ndarray:
        """Servo commands (..., 4) [rad] clipped to the actuators' control ranges."""
        return np.minimum(np.maximum(commands, self._ctrl_lo), self._ctrl_hi)

    def write_clipped(self, command: np.ndarray) -> None:
        """Write one period's already clipped servo commands (4,) [rad] into `data.ctrl`."""
        self._ctrl[self._ctrl_index] = command

    def execute(
        self,
        trajectory: Playable,
        hold: float = 0.0,
        on_step: Callable[[float], None] | None = None,
    ) -> ExecutionLog:
        """Plays `trajectory` stand-alone (the robot alone, Cycle 1, tests), stepping the
        physics itself, then holds its end state for `hold` seconds. An episode never calls
        this: its loop applies a `playback` period by period.

        Args:
            trajectory: The plan (read only).
            hold: Extra time at the final set-point [s].
            on_step: Called after every control period with the trajectory time [s].

        Returns:
            The log, one row per control period (after each period's physics steps).
        """
        play = self.playback(trajectory, hold)
        model, data = self.model, self.data
        n = play.n
        actual = np.empty((n, 4))
        torque = np.empty((n, 3))
        tilt = np.empty(n)
        motors, site = self._motor_ids, self._site
        xmat = data.xmat[self._platform]
        for k in range(n):
            play.apply(k)
            for _ in range(self.substeps):
                mujoco.mj_step(model, data)
            actual[k, :3] = data.site_xpos[site]
            actual[k, 3] = data.qpos[self._axis4_qpos]
            torque[k] = data.actuator_force[motors]
            tilt[k] = np.arccos(min(1.0, max(-1.0, xmat[8])))
            if on_step is not None:
                on_step(float(play.times[k]))
        return ExecutionLog(play.times, play.planned, actual, torque, self._limits, tilt)


class Playback:
    """One trajectory's servo set-points, one row per control period, applied in order.

    Built by `TrajectoryExecutor.playback`. Row k aims at where the TCP should be at the end of
    period k (`times[k]` after the start [s]); the payload's feed-forward share is added with the
    executor's payload at the moment the row is applied.
    """

    def __init__(self, executor, times, planned, base, shift):
        self.executor = executor
        self.times = times
        self.planned = planned
        self._base, self._shift = base, shift
        self.n = len(times)
        self.substeps = executor.substeps
        self._payload = None  # the payload [kg] `_commands` were made for
        self._commands = base

    def apply(self, k: int) -> None:
        """Write row `k`'s commands into the executor's `data.ctrl`."""
        ex = self.executor
        if ex.payload_kg != self._payload:  # every row's clipped commands, once per payload
            self._payload = ex.payload_kg
            self._commands = ex.clip_setpoints(self._base + self._payload * self._shift)
        ex.write_clipped(self._commands[k])
