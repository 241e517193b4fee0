"""The parts of an episode, made afresh at each reset (`build_parts`: a frozen
`sim.episode.parts.EpisodeParts`): the flow, the metrics, the riding, the monitors, the robots'
stations, the perception and the infeed; and the episode's own observation events. Nothing here
steps the physics.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import mujoco
import numpy as np

from planner.decision.energy_cost import EnergyPrice
from planner.decision.interface import DecisionContext
from planner.decision.registry import make_planner
from sim.cell.cell import PICK_Z_NOMINAL, Cell
from sim.cell.depth_noise import ZED_CLASS
from sim.cell.riding import ItemRiding
from sim.cell.suction import SuctionConfig
from sim.config import EpisodeConfig
from sim.config.faults import FaultSchedule
from sim.episode import item_checks
from sim.episode.cycle_timing import cell_cycle_model
from sim.episode.faults.cell_faults import CellFaults
from sim.episode.infeed import Infeed
from sim.episode.parts import EpisodeParts, StepClock, Timeline, Timings
from sim.episode.pick_control import PRESS_DEPTH_M, PickController
from sim.episode.scheduler import BeltRowEvent, PeriodicEvent
from sim.episode.stations import Offers, RobotStation
from sim.errors import InvalidInput
from sim.flow.config import X_INFEED
from sim.flow.generator import Flow, generate_flow, max_items_on_belt
from sim.monitors.energy import ActuatorLog, EnergyMeter
from sim.monitors.mj_warnings import WarningCounter
from sim.monitors.thrown import ThrowWatch
from sim.monitors.visibility import SCALE, VisibilityWatch, belt_slope
from sim.render.segmentation import shared_segmentation
from sim.results.metrics import EpisodeMetrics
from sim.sensing.tracking import Tracker
from sim.sensing.truth import TruthPerception

CHECK_PERIOD_S = 0.02
"""How often items leaving the belt, landing in bins or falling are looked for [s]."""
_OBJECTIVES = {"value_over_distance": "v/d", "value_only": "d=1", "distance_only": "v=1"}


def make_decision_manager(config: EpisodeConfig, robot: int = 0):
    """The configured planner: qlearning and rollout take the [qlearning] section's parameters
    and the observation period as their grid's row period; qlearning draws its random actions
    from the episode's seed; random draws its picks from the episode's seed, each robot of a
    line from its own stream; best_order is given the episode's whole flow (`known_flow`).

    Args:
        config: The episode's configuration.
        robot: The robot's index in the line (0 for a single cell).
    """
    if config.planner in ("qlearning", "rollout"):
        q = config.qlearning
        options = {"seed": config.seed} if config.planner == "qlearning" else {}
        return make_planner(
            config.planner,
            gamma=q.gamma,
            iterations=q.iterations,
            batch_rows=q.batch_rows,
            row_period_s=config.observation_period_s,
            objective=_OBJECTIVES[q.objective],
            **options,
        )
    if config.planner == "random":
        return make_planner("random", seed=config.seed, stream=robot)
    if config.planner == "best_order":
        return make_planner("best_order", **known_flow(config))
    return make_planner(config.planner)


def known_flow(config: EpisodeConfig) -> dict[str, np.ndarray]:
    """The config's whole flow as `best_order` is given it: each item's x at t = 0 (dropped at
    `X_INFEED` at its spawn time, riding at the belt's speed) [m], its y [m] and class id, by
    flow item id."""
    from sim.model.line_model import pool_capacity

    flow = config_flow(config, config.item_catalogue, pool_capacity(config.line_cell))
    return {
        "x0": X_INFEED - config.belt_speed_mps * np.asarray(flow.t_spawn, dtype=float),
        "y": np.asarray(flow.y, dtype=float),
        "classes": np.asarray(flow.class_id, dtype=int),
    }


def check_cell(cell: Cell, config: EpisodeConfig) -> None:
    """Refuse a cell compiled with other model settings than the config's (cup, belt), with
    another number of robots or another catalogue. The robots first: a line's count decides
    its default cup."""
    if len(cell.robots) != config.robot_count:
        allowed = f"the {len(cell.robots)} robot(s) of the cell it runs on"
        raise InvalidInput("robots", allowed, config.robot_count)
    got, want = cell.settings, config.cell_settings
    for key, have, asked in (
        ("cup.diameter_m", got.cup_diameter_m, want.cup_diameter_m),
        ("belt.length_m", got.belt_length_m, want.belt_length_m),
        ("belt.width_m", got.belt_width_m, want.belt_width_m),
    ):
        if have != asked:
            allowed = f"the cell's {have:g} m (a Cell(settings=config.cell_settings) for {asked:g})"
            raise InvalidInput(key, allowed, asked)


_FLOWS: dict[tuple, Flow] = {}
"""The flows made last, by (flow config, catalogue digest, pool capacity): a cell's pool is
sized for a flow (`sim.episode.runner.config_cell`), then its episode runs that flow."""


def config_flow(config: EpisodeConfig, catalogue, capacity: int) -> Flow:
    """The flow of the config's seed on `catalogue`, refused as a pool of `capacity` bodies
    refuses it (`sim.flow.generator.generate_flow`); made once for both callers."""
    key = (config.flow_config(), catalogue.digest, int(capacity))
    flow = _FLOWS.get(key)
    if flow is None:
        flow = generate_flow(key[0], catalogue, key[2])
        if len(_FLOWS) >= 4:
            _FLOWS.clear()
        _FLOWS[key] = flow
    return flow


def episode_flow(config: EpisodeConfig, cell: Cell) -> Flow:
    """The flow of the config's seed, for the cell's catalogue and pool."""
    if cell.catalogue.digest != config.item_catalogue.digest:
        raise InvalidInput(
            "catalogue", "the catalogue the cell was built from", config.catalogue or "default"
        )
    flow = config_flow(config, cell.catalogue, cell.pool_capacity)
    most = max_items_on_belt(flow)
    if most > cell.pool.size:
        allowed = f"flows with at most {cell.pool.size} items on the belt at once (its pool)"
        raise InvalidInput("cell", allowed, f"a flow with {most} (config_cell(config))")
    return flow


def episode_metrics(config: EpisodeConfig, cell: Cell, flow: Flow) -> EpisodeMetrics:
    """The counters of an episode of `flow` (values by class, by item type and per kg; the
    items' masses)."""
    masses = [t.mass for t in flow.item_types(cell.catalogue)]
    return EpisodeMetrics(
        config.values.by_class(cell.materials),
        config.energy_price_eur_per_kwh,
        cell.materials,
        item_values=config.values.of_items(cell.catalogue, flow.type_index.tolist(), masses),
        item_masses=dict(enumerate(masses)),
        n_items=len(flow),
    )


def largest_item_radius(cell: Cell, flow: Flow) -> float:
    """The largest bounding radius of the flow's items, as scaled [m] (0 for no item)."""
    return max(
        (float(cell.pool.props(int(k), f)["geom_rbound"]) for k, f in
         zip(flow.variant, flow.scale, strict=True)),
        default=0.0,
    )  # fmt: skip


def item_riding(config: EpisodeConfig, cell: Cell, radius: float) -> ItemRiding:
    """The episode's item riding (`sim.cell.riding`): riders wake upstream of the robot by
    the largest item's radius `radius` [m]."""
    wake_x = cell.wake_x - max(radius - cell.item_radius, 0.0)
    return ItemRiding(
        cell.model,
        cell.pool,
        wake_x,
        enabled=config.item_riding != "contact",
        in_window=config.item_riding == "path",
        check_period=CHECK_PERIOD_S,
    )


def pick_controllers(config: EpisodeConfig, cell: Cell, flow: Flow) -> list[PickController]:
    """One pick controller per robot of the cell, upstream first, with its robot's pauses and
    the config's cup; on a line each sees what the others' picks aim at (`aimed_by_others`).

    Args:
        config: The episode's configuration.
        cell: The cell.
        flow: The episode's flow (its items, scaled, set how high the robots lift).
    """
    controllers = [
        PickController(
            cell,
            config.belt_speed_mps,
            spec.pick_pause_s,
            spec.place_pause_s,
            items=flow.item_types(cell.catalogue),
            suction=SuctionConfig(vacuum=float(config.cup.vacuum_pa)),
            idle_sleep=spec.idle_sleep,
            robot=k,
        )
        for k, spec in enumerate(config.robots)
    ]
    for k, controller in enumerate(controllers):
        others = [c for j, c in enumerate(controllers) if j != k]
        if others:  # an item touching another robot's target waits (`PickController.plan`)
            controller.aimed_by_others = _aimed_by(others)
    return controllers


def _aimed_by(controllers: list[PickController]):
    """A function giving the slots the picks under way of `controllers` aim at."""

    def aimed() -> list[int]:
        return [c.aimed_slot for c in controllers if c.aimed_slot is not None]

    return aimed


def station_context(config: EpisodeConfig, cell: Cell, view, robot: PickController):
    """The decision context of a robot of the cell (`view`, driven by `robot`): its window,
    bins and cycle-time model (its lift and its pauses), the config's values and prices."""
    return DecisionContext(
        belt_speed=config.belt_speed_mps,
        cycle_model=cell_cycle_model(
            limits=view.limits,
            pick_z=PICK_Z_NOMINAL,
            # The lift the robot makes: the held item's bottom to the clear height.
            lift_height=robot.clear_z + PRESS_DEPTH_M,
            seal_time=robot.config.seal_time,
            release_time=robot.config.release_time,
        ),
        window=view.window,
        bins=view.bins_tuple(),
        values=config.values.for_planning(cell.catalogue),
        energy=EnergyPrice(config.energy_price_eur_per_kwh),
        belt_half_width=cell.belt.geometry.y_half,
    )


def robot_stations(
    config: EpisodeConfig,
    cell: Cell,
    controllers: list[PickController],
    planner,
    radius: float,
    actuator_log: ActuatorLog,
) -> list[RobotStation]:
    """One station per robot of the cell, upstream first: its pick controller, energy meter
    and decision context; `planner` decides for the first robot, a new one of the config's for
    each other.

    Args:
        config: The episode's configuration.
        cell: The cell.
        controllers: The robots' pick controllers (`pick_controllers`).
        planner: The first robot's decision manager.
        radius: The largest item's bounding radius [m].
        actuator_log: The actuators' log every energy meter reads.
    """
    stations = []
    for k, (view, robot) in enumerate(zip(cell.robots, controllers, strict=True)):
        context = station_context(config, cell, view, robot)
        manager = planner if k == 0 else make_decision_manager(config, robot=k)
        manager.reset()
        # How far the cup, or an item hanging from it, reaches around and below its centre
        # [m] (the riders its planned path passes within this of are woken as a pick starts).
        reach = (robot.suction.radius + radius, 2.0 * radius)
        energy = EnergyMeter(
            cell.model,
            cell.data,
            asleep_tree=robot.sleep.tree if robot.sleep.enabled else None,
            log=actuator_log,
            prefix=view.prefix,
        )
        stations.append(RobotStation(k, robot, energy, context, manager, reach))
    return stations


def fault_schedule(config: EpisodeConfig, faults: FaultSchedule | None) -> FaultSchedule:
    """The episode's faults: `faults` when given, else the config's."""
    return faults if faults is not None else config.fault_schedule()


def belt_delay_s(schedule: FaultSchedule) -> float:
    """How much later [s] the belt's faults make the flow pass: every stop's duration, and
    the time a slowdown loses (duration x (1 / factor - 1))."""
    delay = 0.0
    for f in schedule.faults:
        if f.kind == "belt_stop":
            delay += f.duration_s
        elif f.kind == "belt_speed" and f.speed_factor is not None and f.speed_factor < 1.0:
            delay += f.duration_s * (1.0 / f.speed_factor - 1.0)
    return delay


def build_parts(
    config: EpisodeConfig,
    cell: Cell,
    planner,
    wrap_perception=None,
    faults: FaultSchedule | None = None,
) -> EpisodeParts:
    """The parts of an episode of `config` on `cell` (reset here to the config's belt speed),
    `planner` deciding for the first robot (`robot_stations`), `faults` failing its parts
    (None: the config's)."""
    check_cell(cell, config)
    schedule = fault_schedule(config, faults)
    cameras = config.camera_count
    schedule.check_cell(config.robot_count, cameras, None)
    speed = config.belt_speed_mps
    cell.reset(speed)
    flow = episode_flow(config, cell)
    timeline = Timeline.of(cell, flow, speed, config.horizon_s, belt_delay_s(schedule))
    metrics = episode_metrics(config, cell, flow)
    tracker = Tracker(speed)
    controllers = pick_controllers(config, cell, flow)
    bins = item_checks.episode_bins(cell)
    cell.pool.prepare(flow.variant, flow.scale)  # every item's mass properties, once
    radius = largest_item_radius(cell, flow)
    riding = item_riding(config, cell, radius)
    cell.items.ride(riding)
    # MuJoCo's warning counts start at zero (the reset above clears them).
    mj_warnings = WarningCounter(cell.data)
    throw_watch = ThrowWatch(cell.model, cell.pool)
    actuator_log = ActuatorLog(cell.data)  # read by every robot's energy meter
    stations = tuple(robot_stations(config, cell, controllers, planner, radius, actuator_log))
    seen = perception(config, cell, flow)
    return EpisodeParts(
        config=config,
        cell=cell,
        flow=flow,
        timeline=timeline,
        metrics=metrics,
        tracker=tracker,
        offers=Offers(tracker, speed, config.applied_min_class_confidence),
        stations=stations,
        perception=seen if wrap_perception is None else wrap_perception(seen),
        infeed=Infeed(cell.items, flow, config.belt.infeed_hold, riding, metrics),
        riding=riding,
        bins=bins,
        actuator_log=actuator_log,
        mj_warnings=mj_warnings,
        throw_watch=throw_watch,
        clock=StepClock(),
        timings=Timings(),
        faults=schedule,
        fault_state=CellFaults(schedule, stations, cameras),
    )


def perception(config: EpisodeConfig, cell: Cell, flow: Flow):
    """The episode's perception: true items at the camera line, or the belt camera's frames
    through the pipeline (`sim.sensing.perception`); a line's cameras, one per robot, with
    `[camera] per_robot` (the cell compiled with them, `sim.episode.runner.config_cell`)."""
    speed, period = config.belt_speed_mps, config.observation_period_s
    if config.perception == "truth":
        return TruthPerception(cell.items, flow, speed, period)
    # The camera's modules (rendering, the HMMs, the item classifier) are imported only here:
    # a truth episode's start does without them.
    from sim.sensing.item_recording import prepare_classifier
    from sim.sensing.perception import CameraPerception, line_camera_perception

    options = {
        "belt_speed": speed,
        "period_s": period,
        "classifier": config.classifier,
        "depth_noise": ZED_CLASS if config.depth_noise else None,
        "seed": config.seed,
        "mix": config.mix_kwargs,
        "size": config.camera.size,
        "coupled": config.hmm.coupled,
        "encoder": cell.belt.encoder,
    }
    data, catalogue = cell.items.current(), cell.catalogue
    prepare_classifier(config.classifier, catalogue, config.mix_kwargs)  # once a process
    if not (config.camera.per_robot and len(cell.robots) > 1):
        camera = cell.belt_camera(config.camera.size)
        return CameraPerception(cell.model, data, catalogue, camera=camera, **options)
    from sim.cell.camera import camera_name

    prefixes = ("", *(robot.prefix for robot in cell.robots[1:]))
    names = [camera_name(p) for p in prefixes]
    ids = [mujoco.mj_name2id(cell.model, mujoco.mjtObj.mjOBJ_CAMERA, n) for n in names]
    if min(ids) < 0:
        allowed = "a cell compiled with a camera per robot (sim.episode.runner.config_cell)"
        raise InvalidInput("camera.per_robot", allowed, f"no camera {names[ids.index(-1)]}")
    cameras = [cell.belt_camera(config.camera.size, n) for n in names]
    return line_camera_perception(cell.model, data, catalogue, prefixes, cameras, **options)


def own_events(parts: EpisodeParts) -> list:
    """The episode's own scheduled events, in the order they fire when due together: the
    faults' starts and ends (when it has any), the infeed's drops, the perception's
    observations, in camera perception the visibility monitor's, then the item checks
    (`sim.episode.item_checks`). The camera's observations and the monitor's are the belt's
    rows (`BeltRowEvent`: one row of belt travel apart, none while it stands); truth's are
    every observation period of time (it reports where the items are, the belt running or not).
    """
    config, period = parts.config, parts.config.observation_period_s
    if config.perception != "camera":
        events = [parts.infeed, PeriodicEvent(period, observe)]
    else:
        encoder = parts.cell.belt.encoder
        monitor = visibility_monitor(parts.cell, config.camera.size, parts.metrics)
        rows = (BeltRowEvent(period, observe, encoder), BeltRowEvent(period, monitor, encoder))
        events = [parts.infeed, *rows]
    events.append(PeriodicEvent(CHECK_PERIOD_S, item_checks.run_checks))
    if parts.faults:  # only then: a run without faults steps as it always did
        events.insert(0, parts.fault_state)
    return events


def observe(parts: EpisodeParts) -> None:
    """The perception's detections now, handed to the tracker (timed); new tracks booked
    against the true items (`never_detected`)."""
    t = parts.data.time
    t0 = time.perf_counter()
    parts.cell.items.kinematics()
    blind = parts.fault_state.blind_cameras
    detections = parts.perception.observe(t, blind) if blind else parts.perception.observe(t)
    created = parts.tracker.update(detections)
    parts.timings.add("perception", time.perf_counter() - t0, "perception")
    item_checks.attribute(parts, created, t)


def belt_cameras(cell: Cell) -> tuple[str, ...]:
    """The names of the cell's belt cameras, upstream first: the scene's, then any of a
    robot's own (`<prefix>belt_camera`)."""
    from sim.cell.camera import CAMERA_NAME

    names = (CAMERA_NAME, *(robot.prefix + CAMERA_NAME for robot in cell.robots))
    kind = mujoco.mjtObj.mjOBJ_CAMERA
    found = [n for n in dict.fromkeys(names) if mujoco.mj_name2id(cell.model, kind, n) >= 0]
    return tuple(found)


def visibility_monitor(
    cell: Cell, size: tuple[int, int], metrics: EpisodeMetrics
) -> Callable[[EpisodeParts], None]:
    """The visible fraction of each item's top area at every camera observation, booked in
    `metrics` (`never_visible`; `sim.monitors.visibility`), timed as "visibility".

    Args:
        cell: The cell (its belt cameras, items).
        size: The cameras' frame size (width, height) [px].
        metrics: The episode's counters; `never_visible` counted from now on.
    """
    from sim.cell.camera import camera_pose

    renders = []
    renderer = cell.belt_camera(size).renderer  # the cell's cameras' (no context of its own)
    for name in belt_cameras(cell):
        height = (
            camera_pose(cell.model, cell.items.current(), name)[1][2] - cell.belt.geometry.top_z
        )
        slope = belt_slope(float(height), cell.belt.geometry.y_half)
        renders.append(
            shared_segmentation(cell.model, cell.pool, size, SCALE, slope, name, renderer)
        )
    watch = VisibilityWatch(renders, cell.items)
    metrics.on_visibility({})

    def book(parts: EpisodeParts) -> None:
        t0 = time.perf_counter()
        sighting = watch.measure(parts.held())
        metrics.on_visibility(sighting.fractions, sighting.passed)
        parts.timings.add("visibility", time.perf_counter() - t0)

    return book
