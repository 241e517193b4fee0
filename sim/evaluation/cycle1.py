"""ABB's Cycle 1 run in physics: the figure ABB's cycle-per-minute ratings are quoted for.

25 mm up, 305 mm across, 25 mm down with 90 deg of axis 4, 35 ms of vacuum at the far end, and
back, 35 ms of vacuum at home. The trajectory is planned by `planner.motion.pick_cycle.plan_cycle1`
with the payload's limits (`planner.motion.limits.limits_for_payload`) and played on the robot model
(`models/abb_irb360/irb360.xml`) by `sim.cell.executor.TrajectoryExecutor`, with the payload a body
of that mass welded under the cup (free joint + weld equality, so "held" is measured: how far
the payload moves from its attached pose). The load the attachment carries is also checked
against the cell's vacuum cup with `sim.cell.suction`'s criterion: the pull-off force plus the shear
over the lip's friction must stay within lip area x vacuum for that cup to hold it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import mujoco
import numpy as np

from planner.motion.dynamics import GRAVITY
from planner.motion.kinematics import inverse_kinematics
from planner.motion.limits import MAX_PAYLOAD_KG, limits_for_payload
from planner.motion.pick_cycle import plan_cycle1
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from sim.cell.executor import TrajectoryExecutor, lumped_dynamics
from sim.cell.robot import geometry_from_model, set_configuration
from sim.cell.suction import SuctionConfig
from sim.checks import check, is_finite_in
from sim.model.mjcf import ROBOT_ELEMENTS, compile_spec, load_spec
from sim.paths import ROBOT_XML

CYCLE1_START = (-0.1525, 0.0, 0.05)
"""Point A of the cycle [m]: centred under the robot, 50 mm above the belt surface."""

ARRIVAL_TOL = 0.001
"""The vacuum starts once the TCP is within this distance of its stop [m]."""

HELD_TOL = 0.001
"""The payload counts as held while it stays within this distance of its attached pose [m]."""

_PAYLOAD_HALF = 0.03  # half side of the payload cube [m]


@dataclass(frozen=True)
class CycleReport:
    """Figures of one Cycle 1 in physics (SI units; `_mm` fields in millimetres).

    `payload_held`: the payload stayed within `HELD_TOL` of its welded pose throughout.
    `payload_peak_load_n` is the peak pull-off + shear / lip friction it puts on its attachment,
    `vacuum_cup_budget_n` the cell's vacuum cup's lip area x vacuum, and `vacuum_cup_holds`
    whether the first stays within the second (the cell's cup, not only a weld, would hold it).
    """

    payload_kg: float
    cycle_time_s: float
    cycles_per_min: float
    planned_cycle_time_s: float
    peak_torque_nm: list[float]
    torque_limit_nm: float
    peak_torque_ratio: float
    tracking_error_pick_mm: float
    tracking_error_place_mm: float
    peak_tracking_error_mm: float
    axis4_error_at_stops_deg: float
    platform_tilt_max_rad: float
    payload_held: bool
    payload_slip_mm: float
    payload_peak_load_n: float
    vacuum_cup_budget_n: float
    vacuum_cup_holds: bool

    def as_dict(self) -> dict:
        """JSON-ready dictionary."""
        return asdict(self)


def model_with_payload(payload_kg: float, path=None) -> mujoco.MjModel:
    """The robot with a cube of `payload_kg` welded under the cup (no payload body at 0 kg).

    The weld holds the cube's centre `_PAYLOAD_HALF` below the cup's lip, axes aligned with the
    cup's. The robot's file (`path`, default `models/abb_irb360/irb360.xml`) is checked as
    `sortsim run` checks its models (`sim.model.mjcf`): a broken or incomplete one is refused in
    one line naming the file.

    Raises:
        ModelFileError: the robot's file is missing, broken or lacks a name the code needs.
    """
    path = ROBOT_XML if path is None else path
    spec = load_spec(path, ROBOT_ELEMENTS)
    if payload_kg > 0.0:
        while spec.keys:  # keyframes do not know the payload's free joint
            spec.delete(spec.keys[0])
        lip = spec.site("cup_site").pos  # in the cup's frame
        body = spec.worldbody.add_body(name="payload_link")
        body.add_freejoint(name="payload_joint")
        body.add_geom(
            name="payload_geom",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[_PAYLOAD_HALF] * 3,
            mass=payload_kg,
            contype=0,
            conaffinity=0,
            rgba=[0.2, 0.5, 0.9, 1.0],
        )
        weld = spec.add_equality(name="payload_weld", type=mujoco.mjtEq.mjEQ_WELD)
        weld.objtype = mujoco.mjtObj.mjOBJ_BODY
        weld.name1, weld.name2 = "cup_link", "payload_link"
        weld.solref = [0.002, 1.0]
        rel = np.asarray(lip) - np.array([0.0, 0.0, _PAYLOAD_HALF])
        # anchor (3), payload position (3) and orientation (4) in the cup's frame, torque scale
        data = np.array(weld.data, dtype=float)
        data[:11] = np.r_[0.0, 0.0, 0.0, rel, 1.0, 0.0, 0.0, 0.0, 1.0]
        weld.data = data
    return compile_spec(spec, path)


def _attach_payload(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Move the payload to its welded pose under the cup's lip."""
    adr = model.joint("payload_joint").qposadr[0]
    data.qpos[adr : adr + 3] = data.site("cup_site").xpos - np.array([0.0, 0.0, _PAYLOAD_HALF])
    data.qpos[adr + 3 : adr + 7] = data.body("cup_link").xquat
    mujoco.mj_forward(model, data)


def _cup_budget(model: mujoco.MjModel) -> float:
    """Holding force of the cell's vacuum cup, lip area x vacuum [N] (`sim.cell.suction`)."""
    radius = model.geom_size[model.geom("cup_collision").id, 0]
    return float(np.pi * radius**2 * SuctionConfig().vacuum)


def run_cycle1(payload_kg: float) -> CycleReport:
    """Plans and runs Cycle 1 with a payload; see the module docstring.

    Raises:
        InvalidInput: payload outside 0 to 3 kg.
    """
    ok = is_finite_in(payload_kg, 0.0, MAX_PAYLOAD_KG)
    check(ok, "--payload", f"0 to {MAX_PAYLOAD_KG:g} [kg]", payload_kg)
    model = model_with_payload(payload_kg)
    data = mujoco.MjData(model)
    geom = geometry_from_model(model)
    dynamics = lumped_dynamics(model, geom, payload_kg)
    generator = RuckigTrajectoryGenerator(limits_for_payload(payload_kg), geom, dynamics)
    a = np.array(CYCLE1_START)
    chain = plan_cycle1(a, generator)
    set_configuration(model, data, inverse_kinematics(geom, a), 0.0)
    held = payload_kg > 0.0
    if held:
        _attach_payload(model, data)
    slip, where = [], []

    def measure_slip(_t: float) -> None:
        if held:
            pos = data.body("payload_link").xpos
            rel = pos - data.site("cup_site").xpos
            slip.append(np.linalg.norm(rel - np.array([0.0, 0.0, -_PAYLOAD_HALF])))
            where.append(pos.copy())

    executor = TrajectoryExecutor(model, data, geometry=geom, payload_kg=payload_kg)
    log = executor.execute(chain, hold=0.05, on_step=measure_slip)
    stops = {"place": chain.phase_start("vacuum_place"), "pick": chain.phase_start("vacuum_pick")}
    errors, delay = {}, 0.0
    for name, t_arrive in stops.items():
        target = chain.at_time(t_arrive)[0][:3]
        dist = np.linalg.norm(log.actual[:, :3] - target, axis=1)
        due = log.time >= t_arrive - 1e-9
        after = due & (dist <= ARRIVAL_TOL)
        settled = log.time[np.argmax(after)] if np.any(after) else log.time[-1]
        # The vacuum starts once the TCP is within tolerance: any wait past the first control
        # period at or after the planned arrival lengthens the cycle.
        delay += max(0.0, float(settled - log.time[np.argmax(due)]))
        errors[name] = log.error_at(t_arrive)
    rows = [int(np.argmin(np.abs(log.time - t))) for t in stops.values()]
    axis4_err = max(abs(log.actual[i, 3] - log.planned[i, 3]) for i in rows)
    cycle = chain.duration + delay
    load = 0.0
    if held:  # what the cup carries: m (a - g), a from the payload's own motion
        dt = executor.control_dt
        acc = np.diff(np.array(where), 2, axis=0) / dt**2
        force = payload_kg * (acc + [0.0, 0.0, GRAVITY])
        pull, shear = force[:, 2], np.linalg.norm(force[:, :2], axis=1)
        load = float(np.max(np.maximum(pull, 0.0) + shear / SuctionConfig().lip_friction))
    return CycleReport(
        payload_kg=float(payload_kg),
        cycle_time_s=cycle,
        cycles_per_min=60.0 / cycle,
        planned_cycle_time_s=chain.duration,
        peak_torque_nm=log.peak_torque.tolist(),
        torque_limit_nm=float(np.min(log.torque_limit)),
        peak_torque_ratio=log.peak_torque_ratio,
        tracking_error_pick_mm=1e3 * errors["pick"],
        tracking_error_place_mm=1e3 * errors["place"],
        peak_tracking_error_mm=1e3 * float(np.max(log.tracking_error)),
        axis4_error_at_stops_deg=float(np.degrees(axis4_err)),
        platform_tilt_max_rad=float(np.max(log.tilt)),
        payload_held=bool(not held or max(slip) <= HELD_TOL),
        payload_slip_mm=1e3 * float(max(slip)) if held else 0.0,
        payload_peak_load_n=load,
        vacuum_cup_budget_n=_cup_budget(model),
        vacuum_cup_holds=bool(load <= _cup_budget(model)),
    )
