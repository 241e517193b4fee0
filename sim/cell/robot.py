"""Named access to the delta robot inside a compiled model (robot alone or the whole cell).

The geometry the planner uses is read here from the compiled MJCF, so the XML is the one source
of truth. `set_configuration` puts the closed chain (motors, rod hinges, free platform, axis 4)
into the state the analytic kinematics predicts, so a simulation can start anywhere.

Every function takes a keyword `prefix` (default "": the robot's own names, as in the robot's
file and the single cell): the name prefix of one robot of a sorting line
(`sim.model.line_model`, e.g. "r1_" for `r1_motor_1_joint`, `r1_cup_site`).
"""

from __future__ import annotations

import mujoco
import numpy as np

from planner.motion.kinematics import DeltaGeometry, elbows, forward_kinematics
from sim.model.robot_geometry import LEGS, geometry_from_model

RODS = ("a", "b")
MOTOR_JOINTS = tuple(f"motor_{i}_joint" for i in LEGS)
MOTOR_ACTUATORS = tuple(f"motor_{i}" for i in LEGS)


def tcp_position(model: mujoco.MjModel, data: mujoco.MjData, *, prefix: str = "") -> np.ndarray:
    """World position of the cup lip centre (`cup_site`) [m]."""
    return data.site(f"{prefix}cup_site").xpos.copy()


def motor_qpos(model: mujoco.MjModel, data: mujoco.MjData, *, prefix: str = "") -> np.ndarray:
    """Motor angles [rad], shape (3,)."""
    return np.array([data.joint(prefix + name).qpos[0] for name in MOTOR_JOINTS])


def motor_qvel(model: mujoco.MjModel, data: mujoco.MjData, *, prefix: str = "") -> np.ndarray:
    """Motor speeds [rad/s], shape (3,)."""
    return np.array([data.joint(prefix + name).qvel[0] for name in MOTOR_JOINTS])


def platform_tilt(model: mujoco.MjModel, data: mujoco.MjData, *, prefix: str = "") -> float:
    """Angle between the platform's z axis and world z [rad] (0 = level)."""
    zz = data.body(f"{prefix}platform_link").xmat[8]
    return float(np.arccos(np.clip(zz, -1.0, 1.0)))


def loop_closure_error(model: mujoco.MjModel, data: mujoco.MjData, *, prefix: str = "") -> float:
    """Largest gap between the two sites of the robot's connect constraints [m]."""
    worst = 0.0
    p = prefix
    for i in LEGS:
        for r in RODS:
            gap = data.site(f"{p}rod_{i}{r}_tip").xpos - data.site(f"{p}platform_{i}{r}").xpos
            worst = max(worst, float(np.linalg.norm(gap)))
    return worst


def settle_loop(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    tol: float = 1e-12,
    max_iter: int = 30,
    *,
    prefix: str = "",
) -> float:
    """Close the six loops by moving only the passive joints (Gauss-Newton on MuJoCo's kinematics).

    Motors and axis 4 keep their angles; rod hinges and the free platform move so that every
    connect constraint's two sites coincide. Velocities are left untouched.

    Args:
        model: Compiled model containing the robot.
        data: Its data; `qpos` is modified in place and `mj_kinematics` has run on return.
        tol: Stop when the largest site gap is below this [m].
        max_iter: Iteration limit.
        prefix: Name prefix of the robot in `model`; only its passive joints move.

    Returns:
        The remaining largest site gap [m].
    """
    p = prefix
    held = [model.joint(p + n).dofadr[0] for n in (*MOTOR_JOINTS, "axis4_joint")]
    passive = np.ones(model.nv, dtype=bool)
    passive[held] = False
    robot = _robot_dofs(model, p)
    cols = np.flatnonzero(passive & robot)
    pairs = [(f"{p}rod_{i}{r}_tip", f"{p}platform_{i}{r}") for i in LEGS for r in RODS]
    jac1, jac2 = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    for _ in range(max_iter):
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        gaps, rows = [], []
        for s1, s2 in pairs:
            a, b = data.site(s1), data.site(s2)
            gaps.append(a.xpos - b.xpos)
            mujoco.mj_jacSite(model, data, jac1, None, a.id)
            mujoco.mj_jacSite(model, data, jac2, None, b.id)
            rows.append((jac1 - jac2)[:, cols])
        res = np.concatenate(gaps)
        if np.max(np.abs(res)) < tol:
            break
        step = np.linalg.lstsq(np.vstack(rows), -res, rcond=None)[0]
        dq = np.zeros(model.nv)
        dq[cols] = step
        mujoco.mj_integratePos(model, data.qpos, dq, 1.0)
    mujoco.mj_kinematics(model, data)
    return loop_closure_error(model, data, prefix=p)


def _robot_dofs(model: mujoco.MjModel, prefix: str = "") -> np.ndarray:
    """Mask of the degrees of freedom that belong to the robot's bodies."""
    roots = {model.body(f"{prefix}base_link").id, model.body(f"{prefix}platform_link").id}
    mask = np.zeros(model.nv, dtype=bool)
    for dof in range(model.nv):
        body = model.dof_bodyid[dof]
        while body != 0 and body not in roots:
            body = model.body_parentid[body]
        mask[dof] = body in roots
    return mask


def _rod_angles(geom: DeltaGeometry, q: np.ndarray, leg: int, platform: np.ndarray):
    """Swing and tilt of leg `leg`'s rods (both equal in a parallelogram) [rad]."""
    u = geom.radial[leg]
    rod = (platform + geom.platform_radius * u - elbows(geom, q)[leg]) / geom.forearm
    phi, theta = geom.leg_azimuths[leg], q[leg]
    c, s = np.cos(phi), np.sin(phi)
    ct, st = np.cos(theta), np.sin(theta)
    frame = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
        [[ct, 0.0, st], [0.0, 1.0, 0.0], [-st, 0.0, ct]]
    )
    local = frame.T @ rod  # rod direction in the upper arm's frame
    # Rod along -z of its body, rotated first about y (swing) then about x (tilt).
    tilt = np.arcsin(np.clip(local[1], -1.0, 1.0))
    swing = np.arctan2(-local[0], -local[2])
    return swing, tilt


def set_configuration(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    q_motors,
    axis4: float = 0.0,
    geom: DeltaGeometry | None = None,
    *,
    prefix: str = "",
) -> None:
    """Place the whole closed chain in the IK-consistent state of motor angles `q_motors`.

    Sets motors, rod hinges, the free platform (level) and axis 4; zeroes their velocities; sets
    the servo targets to the same angles; runs `mj_forward`.

    Args:
        model: Compiled model containing the robot.
        data: Its data (modified in place).
        q_motors: Motor angles, shape (3,) [rad].
        axis4: Axis 4 angle [rad].
        geom: The model's geometry if already read (saves reading it again).
        prefix: Name prefix of the robot in `model`; the other robots are left as they are.
    """
    p = prefix
    geom = geometry_from_model(model, prefix=p) if geom is None else geom
    q = np.asarray(q_motors, dtype=float).reshape(3)
    platform = forward_kinematics(geom, q) + np.array([0.0, 0.0, geom.tcp_offset])
    for leg, i in enumerate(LEGS):
        swing, tilt = _rod_angles(geom, q, leg, platform)
        _set_hinge(model, data, f"{p}motor_{i}_joint", q[leg])
        for r in RODS:
            _set_hinge(model, data, f"{p}rod_{i}{r}_swing_joint", swing)
            _set_hinge(model, data, f"{p}rod_{i}{r}_tilt_joint", tilt)
    free = model.joint(f"{p}platform_joint")
    data.qpos[free.qposadr[0] : free.qposadr[0] + 7] = np.r_[platform, 1.0, 0.0, 0.0, 0.0]
    data.qvel[free.dofadr[0] : free.dofadr[0] + 6] = 0.0
    _set_hinge(model, data, f"{p}axis4_joint", axis4)
    set_motor_targets(model, data, q, axis4, prefix=p)
    mujoco.mj_forward(model, data)


def _set_hinge(model: mujoco.MjModel, data: mujoco.MjData, name: str, value: float) -> None:
    joint = model.joint(name)
    data.qpos[joint.qposadr[0]] = value
    data.qvel[joint.dofadr[0]] = 0.0


def set_motor_targets(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    q,
    axis4: float = 0.0,
    qdot=None,
    axis4_dot: float = 0.0,
    *,
    prefix: str = "",
) -> None:
    """Write servo set-points for the three motors and axis 4.

    MuJoCo's position servo pushes with kp (ctrl - q) - kv qdot, i.e. it damps towards zero
    speed. Given the reference speed, the set-point is led by (kv / kp) qdot_ref so the servo
    acts as kp (q_ref - q) + kv (qdot_ref - qdot) and does not lag on moving references.

    Args:
        model: Compiled model containing the robot.
        data: Its data (`data.ctrl` is written).
        q: Motor angle set-points, shape (3,) [rad].
        axis4: Axis 4 set-point [rad].
        qdot: Reference motor speeds, shape (3,) [rad/s]; None for a fixed set-point.
        axis4_dot: Reference axis 4 speed [rad/s].
        prefix: Name prefix of the robot in `model`.
    """
    ids = _servo_ids(model, prefix)  # called every control period: no name lookups here
    targets = np.empty(4)
    targets[:3], targets[3] = np.asarray(q, dtype=float).reshape(3), axis4
    speeds = np.zeros(4)
    if qdot is not None:
        speeds[:3] = np.asarray(qdot, dtype=float).reshape(3)
    speeds[3] = axis4_dot
    kp, kv = model.actuator_gainprm[ids, 0], -model.actuator_biasprm[ids, 2]
    value = targets + (kv / kp) * speeds
    ctrlrange = model.actuator_ctrlrange[ids]
    data.ctrl[ids] = np.clip(value, ctrlrange[:, 0], ctrlrange[:, 1])


_SERVO_IDS: dict[tuple[int, str], tuple[mujoco.MjModel, np.ndarray]] = {}


def _servo_ids(model: mujoco.MjModel, prefix: str = "") -> np.ndarray:
    """Actuator ids of the three motors and axis 4 (cached per model and robot)."""
    hit = _SERVO_IDS.get((id(model), prefix))
    if hit is None or hit[0] is not model:
        ids = np.array([model.actuator(prefix + n).id for n in (*MOTOR_ACTUATORS, "axis4")])
        hit = _SERVO_IDS[(id(model), prefix)] = (model, ids)
    return hit[1]
