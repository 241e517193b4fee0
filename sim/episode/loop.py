"""The loop of one episode: the only place that steps the physics while an episode runs.

In the manner of dm_control's `Environment.step` with task hooks. Each physics step is
`before_step` (the robot's executor writes its set-points) -> `mj_step` -> after-step hooks
(the cup; then the scheduler: items dropped at the infeed, observations, item checks with
MuJoCo's warnings, items thrown off the belt, the bins and riding, video frames) -> the pick's
outcome once the robot is free again. While the robot idles the physics is stepped in blocks
up to the next scheduled event; while it moves, one step per control period. Decisions are
the episode's public surface: `step_until_decision` advances until the robot is free and a
choice is needed, `apply` takes the choice (from the configured decision manager in `run`, or
from outside: a Gymnasium agent, a line coordinator). The episode ends when every item has
been dropped and left the belt (picked, missed, dropped) and the robot is idle.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import replace

import mujoco
import numpy as np

from planner.decision.energy_cost import EnergyPrice
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem
from planner.decision.line_coordination import LineRobot, offered_items
from planner.decision.registry import make_planner
from sim.cell.cell import PICK_Z_NOMINAL, Cell
from sim.cell.depth_noise import ZED_CLASS
from sim.cell.held_slots import held_mask
from sim.cell.riding import ItemRiding, PlannedPath
from sim.cell.suction import SuctionConfig
from sim.episode.config import EpisodeConfig
from sim.episode.cycle_timing import cell_cycle_model
from sim.episode.infeed import MAX_HOLD_S, MAX_RAISE_M, RAISE_STEP_M, dropped_into
from sim.episode.pick_control import PRESS_DEPTH_M, PickController, PickOutcome
from sim.errors import InvalidInput
from sim.flow.config import X_INFEED
from sim.flow.generator import generate_flow
from sim.flow.ground_truth import yaw_from_xmat
from sim.monitors.bins import Bins
from sim.monitors.energy import ActuatorLog, EnergyMeter
from sim.monitors.mj_warnings import WarningCounter
from sim.monitors.thrown import ThrowWatch
from sim.render.video import overlay_of
from sim.results.metrics import EpisodeMetrics, PickRecord
from sim.sensing.attribution import attributed_item
from sim.sensing.confidence import is_unsure, sure_items
from sim.sensing.perception import CameraPerception, TruthPerception
from sim.sensing.tracking import Tracker

log = logging.getLogger(__name__)

DECIDE_PERIOD_S = 0.02
"""How often an idle robot asks the decision manager again [s]."""
MAX_LEAD_S = 1.0
"""A pick is started only if the cup meets the item within this time; an item further
upstream is waited for and decided on again (its position is fresher by then) [s]."""
WAIT_STEP_S = 0.25
"""Longest wait before deciding again on an item still upstream [s]."""
RETRY_AFTER_S = 0.25
"""An item the cup cannot meet now (a neighbour in the way, a plan outside the motor limits as
it enters the window) is offered again after this long, while it is still on the belt [s]. The
camera reports an item once; dropping its track would lose it for good."""
MAX_FAILURES = 2
"""Attempts after which truth mode gives an item up (it is re-detected every period)."""
CHECK_PERIOD_S = 0.02
"""How often items leaving the belt, landing in bins or falling are looked for [s]."""
BELOW_BELT_Z = -0.1
"""An item whose centre is this far below the belt surface has left it [m]."""
DISCARD_MARGIN_M = 0.15
"""An item this far past the reachable window's downstream edge is out of the robot's reach
(the scene's cup radius and the item's half length included; a larger cup adds its extra
radius, `Cell.cup_extra_m`) [m]."""
SETTLE_S = 2.0
"""Time after the last item left before the episode may end (falls into bins) [s]."""
LINE_PICK_TIME_S = 0.75
"""A pick's duration a line's coordination assumes before a robot has picked [s] (the
headline episode's mean cycle is 0.73 s)."""
_OBJECTIVES = {"value_over_distance": "v/d", "value_only": "d=1", "distance_only": "v=1"}


def _check_cell(cell: Cell, config: EpisodeConfig) -> None:
    """Refuse a cell compiled with other model settings than the config's (cup, belt)."""
    got, want = cell.settings, config.cell_settings
    for key, have, asked in (
        ("cup.diameter_m", got.cup_diameter_m, want.cup_diameter_m),
        ("belt.length_m", got.belt_length_m, want.belt_length_m),
    ):
        if have != asked:
            allowed = f"the cell's {have:g} m (a Cell(settings=config.cell_settings) for {asked:g})"
            raise InvalidInput(key, allowed, asked)


def _prefixed(robot_cell) -> dict:
    """The name prefix of a line's robot (`prefix=`), nothing for a one-robot cell."""
    prefix = getattr(robot_cell, "prefix", "")
    return {"prefix": prefix} if prefix else {}


def make_decision_manager(config: EpisodeConfig):
    """The configured planner: qlearning and rollout take the [qlearning] section's parameters
    and the observation period as their grid's row period; qlearning draws its random actions
    from the episode's seed."""
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
    return make_planner(config.planner)


class RobotStation:
    """One robot of an episode: its pick controller (executor, cup), motor energy meter,
    decision context and manager, and the pick under way. A cell has one; a line one per robot
    (`robot_cells`), all stepped by the one loop.

    Args:
        index: The robot's index, 0 upstream.
        robot: Its pick controller.
        energy: Its motors' energy meter.
        context: Its decision context (its window, its bins).
        planner: Its decision manager.
        path_reach: (around, below) how far the cup, or an item hanging from it, reaches from
            the cup's centre [m] (riders its planned path passes are woken as a pick starts).
    """

    def __init__(self, index, robot, energy, context, planner, path_reach):
        self.index, self.robot, self.energy = index, robot, energy
        self.context, self.planner, self.path_reach = context, planner, path_reach
        self.next_decision = 0.0
        self.current_pick = None  # the track being picked (shown in the video)
        # (track, choice, energy reading at the start, travel [m]) of the pick under way
        self.pick_started: tuple | None = None
        self.started_at = 0.0  # when the pick under way started [s]
        self.path: PlannedPath | None = None  # the cup's planned path of the pick under way
        self.picks_done, self.pick_time_sum = 0, 0.0  # its finished picks and their time [s]
        self.cup_events_seen = 0


class Episode:
    """One episode on a `Cell`, steppable from outside (see the module docstring).

    Lifecycle as Gymnasium's `Env`: `reset(seed)`, then `step_until_decision()` and
    `apply(choice)` until the former returns False, then `close()`; usable with `with`.
    `run()` is that loop with the configured decision manager choosing.

    Args:
        config: The episode's configuration.
        cell: The compiled cell it runs on (reset by `reset`).
        video: A `sim.render.video.VideoRecorder`, anything with its interface (`due`,
            `next_frame_time`, `capture(data, overlay)`, `close`, `abort`; e.g.
            `sim.render.live_view.LiveView`), or None.
        progress: Called with (fraction, status line) about once per simulated second.
        planner: A decision manager object (`choose`, `reset`); the config's when omitted.
    """

    def __init__(self, config: EpisodeConfig, cell: Cell, video=None, progress=None, planner=None):
        self.config, self.cell, self.video, self.progress = config, cell, video, progress
        self.model, self.data = cell.model, cell.data
        self.planner = planner if planner is not None else make_decision_manager(config)
        self.stations: list[RobotStation] = []
        self._deciding: RobotStation | None = None
        self._ready = False

    # The single robot's (the first robot's) parts, by their names of a one-robot cell.
    @property
    def robot(self) -> PickController:
        """The pick controller of the robot deciding now (the first robot between decisions)."""
        return self._station().robot

    @property
    def context(self) -> DecisionContext:
        """The decision context of the robot deciding now (the first between decisions)."""
        return self._station().context

    @property
    def deciding_robot(self) -> int:
        """Index of the robot deciding now, 0 upstream (the first robot between decisions)."""
        return self._station().index

    @property
    def energy(self) -> EnergyMeter:
        """The first robot's motor energy meter (the line's: `stations`)."""
        return self.stations[0].energy

    @property
    def current_pick(self):
        """The track the first robot is picking (None when idle)."""
        return self.stations[0].current_pick if self.stations else None

    def _station(self) -> RobotStation:
        return self._deciding if self._deciding is not None else self.stations[0]

    def _robot_cells(self) -> list:
        """The robots' cells: the cell itself for one robot, a line's `robot_cells`."""
        return list(getattr(self.cell, "robot_cells", None) or [self.cell])

    def __enter__(self) -> Episode:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close(aborted=exc_type is not None)

    def reset(self, seed: int | None = None) -> None:
        """Start the episode afresh: the cell reset, the flow of `seed` (the config's when
        None), every counter at zero, the decision manager reset."""
        config = self.config if seed is None else replace(self.config, seed=int(seed))
        self.config = config
        cell = self.cell
        _check_cell(cell, config)
        n_robots = len(self._robot_cells())
        if n_robots != config.robots:
            allowed = f"the {n_robots} robot(s) of the cell it runs on"
            raise InvalidInput("robots", allowed, config.robots)
        self.speed = config.belt_speed_mps
        cell.reset(self.speed)
        if cell.catalogue.digest != config.item_catalogue.digest:
            raise InvalidInput(
                "catalogue", "the catalogue the cell was built from", config.catalogue or "default"
            )
        self.flow = generate_flow(config.flow_config(), cell.catalogue, cell.pool.size)
        self.t_last_spawn = float(self.flow.t_spawn[-1]) if len(self.flow) else 0.0
        self.x_discard = float(np.nanmax(cell.window.x_exit)) + DISCARD_MARGIN_M + cell.cup_extra_m
        # When the last item has passed the robot (the end of a normal episode) and a cap.
        self.t_end = self.t_last_spawn + (self.x_discard - X_INFEED) / self.speed + SETTLE_S
        self.t_cap = self.t_end + 10.0
        materials = cell.materials
        type_values = config.values.of_types(cell.catalogue)
        self.metrics = EpisodeMetrics(
            config.values.by_class(materials),
            config.energy_price_eur_per_kwh,
            materials,
            item_values={
                i: type_values[int(k)]
                for i, k in enumerate(self.flow.type_index.tolist())
                if int(k) in type_values
            },
        )
        self.tracker = Tracker(self.speed)
        pauses = config.robot
        robots = [
            PickController(
                robot_cell,
                self.speed,
                pauses.pick_pause_s,
                pauses.place_pause_s,
                items=self.flow.item_types(cell.catalogue),
                suction=SuctionConfig(vacuum=float(config.cup.vacuum_pa)),
                idle_sleep=pauses.idle_sleep,
                **_prefixed(robot_cell),
            )
            for robot_cell in self._robot_cells()
        ]
        prefixes = tuple(getattr(rc, "prefix", "") for rc in self._robot_cells())
        self.bins = Bins(self.model, self.data, cell.pool, materials, prefixes)
        # Riders wake upstream of the robot by the largest item's radius (`sim.cell.riding`).
        radius = max(
            (float(cell.pool.props(int(k), f)["geom_rbound"]) for k, f in
             zip(self.flow.variant, self.flow.scale, strict=True)),
            default=0.0,
        )  # fmt: skip
        wake_x = cell.wake_x - max(radius - cell.item_radius, 0.0)
        self.riding = ItemRiding(
            self.model,
            cell.pool,
            wake_x,
            enabled=config.item_riding != "contact",
            in_window=config.item_riding == "path",
            check_period=CHECK_PERIOD_S,
        )
        # MuJoCo's warning counts start at zero (the reset above clears them).
        self.mj_warnings = WarningCounter(self.data)
        self.throw_watch = ThrowWatch(self.model, cell.pool)
        self._timestep = float(self.model.opt.timestep)  # [s]
        self.actuator_log = ActuatorLog(self.data)  # read by every robot's energy meter
        self.stations = []
        for k, (robot_cell, robot) in enumerate(zip(self._robot_cells(), robots, strict=True)):
            context = DecisionContext(
                belt_speed=self.speed,
                cycle_model=cell_cycle_model(
                    limits=robot_cell.limits,
                    pick_z=PICK_Z_NOMINAL,
                    # The lift the robot makes: the held item's bottom to the clear height.
                    lift_height=robot.clear_z + PRESS_DEPTH_M,
                    seal_time=robot.config.seal_time,
                    release_time=robot.config.release_time,
                ),
                window=robot_cell.window,
                bins=robot_cell.bins_tuple(),
                values=config.values.of_materials(materials),
                energy=EnergyPrice(config.energy_price_eur_per_kwh),
            )
            planner = self.planner if k == 0 else make_decision_manager(config)
            planner.reset()
            # How far the cup, or an item hanging from it, reaches around and below its centre
            # [m] (the riders its planned path passes within this of are woken as a pick starts).
            reach = (robot.suction.radius + radius, 2.0 * radius)
            energy = EnergyMeter(
                robot_cell.model,
                self.data,
                asleep_tree=robot.sleep.tree if robot.sleep.enabled else None,
                log=self.actuator_log,
                **_prefixed(robot_cell),
            )
            self.stations.append(RobotStation(k, robot, energy, context, planner, reach))
        self._deciding = None
        period = config.observation_period_s
        if config.perception == "truth":
            self.perception = TruthPerception(self.data, cell.pool, self.flow, self.speed, period)
        else:
            self.perception = CameraPerception(
                self.model,
                self.data,
                cell.catalogue,
                self.speed,
                period,
                camera=cell.belt_camera(config.camera.size),
                classifier=config.classifier,
                depth_noise=ZED_CLASS if config.depth_noise else None,
                seed=config.seed,
                mix=config.flow.flow_kwargs(),
                size=config.camera.size,
            )
        # Scheduled events: the next drop, observation, item check and decision [s].
        self.next_spawn = 0
        self.infeed_holds = 0  # items the infeed held back (sim.episode.infeed)
        self._waiting: dict[int, float] = {}  # flow index of an item held back -> since [s]
        self.next_obs = 0.0
        self.next_check = 0.0
        self.failures: dict[int, int] = {}  # failed attempts per true item id (truth mode)
        self.not_before: dict[int, float] = {}  # track id -> when it may be offered again [s]
        self.timings = dict.fromkeys(
            ("physics", "perception", "decision", "planning", "video"), 0.0
        )
        self.decisions = 0
        self.latencies: dict[str, list[float]] = {"perception": [], "decision": [], "plan": []}
        self._candidates: list[TrackedItem] = []
        # track id -> (its probabilities, its item) as the last `_tracked_items` made them
        self._track_items: dict[int, tuple[np.ndarray, TrackedItem]] = {}
        self._last_report = -1.0
        self._closed_out = False
        self._ready = True

    def close(self, aborted: bool = False) -> None:
        """Release the perception's renderer and finish (or, `aborted`, discard) the video."""
        perception = getattr(self, "perception", None)
        if perception is not None:
            perception.close()
        if self.video is not None:
            if aborted:
                self.video.abort()
            else:
                self.video.close()
            self.video = None

    # ----- the public stepping interface --------------------------------------------------------

    def step_until_decision(self) -> bool:
        """Advance the physics until the robot is free and a choice is due among the tracked
        items (`candidates()`, `robot_state()`, `context`); False once the episode has ended."""
        if not self._ready:
            self.reset()
        self._deciding = None
        while not self._finished():
            t = self.data.time
            items = None  # the tracked items now, once for every robot free now
            for station in self.stations:
                if not station.robot.busy and t + 1e-9 >= station.next_decision:
                    station.next_decision = t + DECIDE_PERIOD_S
                    if items is None:
                        items = self._tracked_items(t)
                    self._candidates = self._offered(station, items, t)
                    if self._candidates:
                        self._deciding = station
                        self.riding.sync(self.data)  # a decision and a plan read the items
                        return True
            self._step()
        self.riding.sync(self.data)
        readings = [s.energy.reading() for s in self.stations]
        self.metrics.on_energy(*(sum(r[i] for r in readings) for i in (0, 1)))
        self._close_out()
        return False

    def candidates(self) -> list[TrackedItem]:
        """The tracked items a choice is made among, at the current sim time."""
        return list(self._candidates)

    def robot_state(self) -> RobotState:
        """Where the robot rests and the current sim time."""
        return RobotState(tuple(self.robot.rest), float(self.data.time))

    def choose(self) -> Choice | None:
        """The configured decision manager's choice now (timed for the benchmarks)."""
        t0 = time.perf_counter()
        station = self._station()
        choice = station.planner.choose(self._candidates, self.robot_state(), station.context)
        dt = time.perf_counter() - t0
        self.timings["decision"] += dt
        self.latencies["decision"].append(dt)
        self.decisions += 1
        return choice

    def apply(self, choice: Choice | None) -> bool:
        """Act on a choice: start the pick when the cup can meet the item soon, else wait and
        decide again later (None: nothing now). True if a pick started."""
        t = float(self.data.time)
        t1 = time.perf_counter()
        if choice is None:
            return False
        station = self._station()
        robot = station.robot
        if choice.meet_time - t > MAX_LEAD_S:
            # Far upstream: wait where we are and decide again with fresher positions.
            station.next_decision = t + min(choice.meet_time - t - MAX_LEAD_S, WAIT_STEP_S)
            return False
        track = self.tracker.get(choice.item_id)
        x = track.x_at(t, self.speed)
        intercept = robot.plan(x, track.y, choice.bin_class)
        self.timings["planning"] += time.perf_counter() - t1
        self.latencies["plan"].append(time.perf_counter() - t1)
        if not intercept.feasible:
            # Not now: offered again shortly (the tracker prunes it once it is past the robot).
            self.not_before[track.track_id] = t + RETRY_AFTER_S
            return False
        if intercept.meet_time > MAX_LEAD_S + WAIT_STEP_S:
            station.next_decision = t + WAIT_STEP_S  # the cycle model was optimistic: wait
            return False
        station.current_pick = track
        self.tracker.remove(track.track_id)  # no other robot is offered it now
        # The thesis's distance of the pick (rest -> item -> bin, in the belt's plane) [m].
        meet_xy = intercept.pick_xyz[:2]
        drop_xy = np.asarray(station.context.bin_of(choice.bin_class)[:2], dtype=float)
        travel = float(np.linalg.norm(meet_xy - robot.rest[:2]) + np.linalg.norm(drop_xy - meet_xy))
        station.pick_started = (track, choice, station.energy.reading(), travel)
        station.started_at = t
        robot.start(intercept, -1 if track.true_id is None else int(track.true_id))
        station.path = None
        if self.riding.in_window:
            station.path = PlannedPath.of(intercept.plan.chain, t, *station.path_reach)
            self.riding.wake_on_path(self.data, station.path, self.speed)
        return True

    def run(self) -> None:
        """Simulate until the episode ends, the configured decision manager choosing."""
        while self.step_until_decision():
            self.apply(self.choose())

    # ----- stepping ------------------------------------------------------------------------------

    def _step(self) -> None:
        """The one physics step of the episode: one control period while a pick is under way
        (set-points, step, cup, scheduler, outcome), else one block up to the next scheduled
        event (the robot holds its set-points)."""
        busy = [s for s in self.stations if s.robot.busy]
        for station in busy:
            station.robot.before_step()
        nstep = 1 if busy else self._idle_steps()
        mujoco.mj_step(self.model, self.data, nstep=nstep)
        duration = nstep * self._timestep
        self.riding.carry(duration)
        self.actuator_log.record(duration)
        for station in busy:
            station.robot.after_step()
        self._after_step()
        if busy:
            for station in busy:
                outcome = station.robot.poll()
                if outcome is not None:
                    self._finish_pick(station, outcome)
            return
        t = self.data.time
        if self.progress is not None and t - self._last_report >= 1.0:
            self._last_report = t
            self.progress(min(t / self.t_end, 1.0), self.status_text())

    def _after_step(self) -> None:
        """The scheduler: everything due at the current sim time except decisions."""
        t = self.data.time
        spawn_due = self._waiting or (
            self.next_spawn < len(self.flow) and self.flow.t_spawn[self.next_spawn] <= t
        )
        observe_due = t + 1e-9 >= self.next_obs
        check_due = t + 1e-9 >= self.next_check
        frame_due = self.video is not None and self.video.due(t)
        if spawn_due or observe_due or check_due or frame_due:
            self.riding.sync(self.data)  # the riders where the belt has carried them
        if spawn_due:
            self._spawn()
        if observe_due:
            self._observe(t)
            self.next_obs += self.config.observation_period_s
        if check_due:
            self._check_items(t)
            self.next_check += CHECK_PERIOD_S
        if frame_due:
            t0 = time.perf_counter()
            self.video.capture(self.data, overlay_of(self, t))
            self.timings["video"] += time.perf_counter() - t0

    def _finish_pick(self, station: RobotStation, outcome: PickOutcome) -> None:
        """Book a finished pick and decide again at once."""
        track, choice, (mech0, elec0), travel = station.pick_started
        station.pick_started = None
        station.picks_done += 1
        station.pick_time_sum += outcome.t_end - outcome.t_start
        mech, elec = station.energy.reading()
        station.current_pick = None
        if not outcome.held_to_bin and track.true_id is not None:
            self.failures[track.true_id] = self.failures.get(track.true_id, 0) + 1
        if outcome.item_id >= 0:  # the cup may have sealed on a neighbour: forget its track too
            self.tracker.remove_true(outcome.item_id)
        true_class = int(self.flow.class_id[outcome.item_id]) if outcome.item_id >= 0 else None
        if true_class is None and track.true_id is not None:
            true_class = int(self.flow.class_id[track.true_id])
        self.metrics.on_pick(
            PickRecord(
                t_start_s=outcome.t_start,
                t_end_s=outcome.t_end,
                item_id=outcome.item_id if outcome.item_id >= 0 else (track.true_id or -1),
                true_class=true_class,
                predicted_class=track.predicted_class,
                bin=choice.bin_class,
                success=outcome.held_to_bin,
                travel_m=travel,
                energy_mech_j=mech - mech0,
                energy_elec_j=elec - elec0,
                sealed=outcome.sealed,
                robot=station.index,
            )
        )
        station.next_decision = self.data.time

    def _spawn(self) -> None:
        """Hand the due items over to the belt (at its speed, as from an infeed conveyor); with
        `belt.infeed_hold`, an item that would drop into one already there is held back
        (`sim.episode.infeed`)."""
        first = self.next_spawn
        if self.config.belt.infeed_hold:
            self.next_spawn, dropped = self._feed_holding(first)
        else:
            self.next_spawn = self.cell.pool.feed(self.data, self.flow, first)
            dropped = range(first, self.next_spawn)
        mujoco.mj_kinematics(self.model, self.data)  # poses of the new items for the checks
        # An item dropped partly onto a flat one: that one touches again if it was riding.
        landing = [i for i in dropped if self.flow.z_drop[i] > 0]
        if landing:
            self.riding.wake_near(self.data, [self.cell.pool.slot_of(i) for i in landing])
        for i in dropped:
            self.metrics.on_entered(i, int(self.flow.class_id[i]))

    def _feed_holding(self, first: int) -> tuple[int, list[int]]:
        """`ItemPool.feed`, holding back an item that would drop into an item on the belt:
        it drops at the infeed's end once it drops clear (or has waited `MAX_HOLD_S`), while
        the items due after it drop as planned. Returns the next flow index and the items
        dropped now."""
        pool, data, flow = self.cell.pool, self.data, self.flow
        t, i = float(data.time), first
        dropped, waiting = [], {}
        due = [(k, X_INFEED, since) for k, since in self._waiting.items()]
        while i < len(flow) and flow.t_spawn[i] <= t:
            due.append((i, X_INFEED + pool.belt.speed * (t - float(flow.t_spawn[i])), t))
            i += 1
        for k, x, since in due:
            slot = pool.drop(data, flow, k, x)
            mujoco.mj_kinematics(self.model, data)
            if dropped_into(self.model, data, pool, slot):
                if t - since < MAX_HOLD_S:
                    pool.park(data, slot)
                    self.infeed_holds += k not in self._waiting
                    waiting[k] = since
                    continue
                # Waited long enough (an item stuck at the infeed): dropped onto it instead.
                self._drop_above(k, x, slot)
            dropped.append(k)
        self._waiting = waiting
        return i, dropped

    def _drop_above(self, k: int, x: float, slot: int) -> None:
        """Drop flow item `k`, which lies in `slot` inside another item, raised in steps of
        `RAISE_STEP_M` until it clears every item (at most `MAX_RAISE_M`), as off a chute."""
        pool, data = self.cell.pool, self.data
        lift = 0.0
        while True:
            pool.park(data, slot)
            lift += RAISE_STEP_M
            slot = pool.drop(data, self.flow, k, x, raise_m=lift)
            mujoco.mj_kinematics(self.model, data)
            if lift >= MAX_RAISE_M or not dropped_into(self.model, data, pool, slot):
                return

    def _observe(self, t: float) -> None:
        t0 = time.perf_counter()
        mujoco.mj_kinematics(self.model, self.data)
        created = self.tracker.update(self.perception.observe(t))
        dt = time.perf_counter() - t0
        self.timings["perception"] += dt
        self.latencies["perception"].append(dt)
        self._attribute(created, t)

    def _attribute(self, created: list, t: float) -> None:
        """Book the true items the new tracks are of (the metrics' `never_detected`;
        `sim.sensing.attribution`: bookkeeping the robot never sees)."""
        if not created:
            return
        items_xy, shapes = {}, {}
        if any(track.true_id is None for track in created):
            pool, held = self.cell.pool, self._held_slots()
            for slot in pool.active_slots():
                if slot not in held:
                    body = pool.body_ids[slot]
                    x, y = self.data.xpos[body][:2]
                    item_id = int(pool.item_ids[slot])
                    items_xy[item_id] = (float(x), float(y))
                    yaw = float(yaw_from_xmat(self.data.xmat[body][None])[0])
                    shapes[item_id] = (yaw, pool.item_type(int(slot)))
        gate = self.tracker.match_radius
        for track in created:
            item_id = attributed_item(track, t, self.speed, items_xy, gate, shapes)
            if item_id is not None:
                self.metrics.on_detected(item_id)

    def _check_items(self, t: float) -> None:
        """Every `CHECK_PERIOD_S`: MuJoCo's new warnings, items thrown off the belt
        (`sim.monitors.thrown`), items past the robot or the belt's end, landings, riding."""
        pool, data = self.cell.pool, self.data
        held_slots = self._held_slots()
        held = held_slots[0] if len(held_slots) == 1 else None
        self.metrics.on_warnings(self.mj_warnings.update())  # a MujocoWarning names them
        # Items a cup let go of over a bin fall into it: not thrown, never judged as such.
        for station in self.stations:
            cup = station.robot.suction
            for event in cup.events[station.cup_events_seen :]:
                if event.kind == "released":
                    self.throw_watch.note_released(event.item_id)
            station.cup_events_seen = len(cup.events)
        for throw in self.throw_watch.update(data, held_slots if len(held_slots) > 1 else held):
            doing = "; ".join(s.robot.activity() for s in self.stations)
            self.metrics.on_thrown(throw, doing)
            log.warning(
                "seed %d, t %.2f s: item %d thrown off the belt (%s) while the robot was at %s",
                self.config.seed,
                throw.time,
                throw.item_id,
                throw.reason,
                doing,
            )
        active = pool.active_slots()
        pos = data.xpos[pool.body_ids[active]]
        passed = (pos[:, 0] > self.x_discard) & (pos[:, 2] > BELOW_BELT_Z)  # passed the robot
        for slot in active[passed & ~held_mask(active, held_slots)].tolist():  # discarded
            item_id = pool.park(data, slot)
            self.metrics.on_missed(item_id)
            self._book_unsure(self.tracker.remove_true(item_id))
        for item_id in pool.park_missed(data):  # past the belt's end (e.g. pushed along)
            self.metrics.on_missed(item_id)
            self._book_unsure(self.tracker.remove_true(item_id))
        for landing in self.bins.update(data, held_slots if len(held_slots) > 1 else held):
            if landing.bin is None or landing.item_id not in self.throw_watch.released:
                # Only what the cup carried and let go of over a bin is picked; an item that
                # reached a bin otherwise (knocked off the belt) is dropped.
                self.metrics.on_dropped(landing.item_id)
            else:
                self.metrics.on_binned(landing.item_id, landing.true_class, landing.bin_class)
            self.tracker.remove_true(landing.item_id)
        self._book_unsure(self.tracker.prune(t, self.x_discard))
        paths = [s.path for s in self.stations if s.robot.busy and s.path is not None]
        self.riding.update(data, held_slots if len(held_slots) > 1 else held, busy_paths=paths)

    def _offered(self, station: RobotStation, items: list[TrackedItem], t: float):
        """The items a free robot of a line may choose among (`coordination`); all of them
        for one robot. A robot's pick is taken to last its mean cycle so far."""
        if len(self.stations) <= 1 or not items:
            return items
        line = []
        for s in self.stations:
            free_at = s.started_at + self._pick_time(s) if s.robot.busy else t
            sorted_here = self.config.robot_class_ids[s.index]  # None: every material
            line.append(LineRobot(s.context, max(free_at, t), sorted_here))
        return offered_items(
            self.config.coordination, items, line, station.index, t, self._pick_time(station)
        )

    def _pick_time(self, station: RobotStation) -> float:
        """Mean duration of the robot's picks so far [s] (`LINE_PICK_TIME_S` before any)."""
        if not station.picks_done:
            return LINE_PICK_TIME_S
        return station.pick_time_sum / station.picks_done

    def robot_columns(self, sim_s: float) -> dict[str, object]:
        """A line's episodes.csv columns: robots, coordination, each robot's picks, picks per
        minute, utilisation and energy (`sim.results.outputs.line_columns`); none for one."""
        if len(self.stations) <= 1:
            return {}
        out: dict[str, object] = {
            "robots": len(self.stations),
            "coordination": self.config.coordination,
        }
        for s in self.stations:
            out |= self.metrics.robot_row(s.index, sim_s, s.energy.reading()[1])
        return out

    def _held_slots(self) -> list[int]:
        """The pool slots the robots' cups hold now (sealed), robot by robot."""
        cups = (s.robot.suction for s in self.stations)
        return [cup.held_slot for cup in cups if cup.held_slot is not None]

    def _tracked_items(self, t: float) -> list[TrackedItem]:
        """The tracked items every decision manager chooses among: the confidence rule
        (`sim.sensing.confidence`) applied here, once for all of them."""
        items, made = [], {}
        for tr in self.tracker.tracks():
            if self.failures.get(tr.true_id, 0) >= MAX_FAILURES:
                continue  # truth mode: an item the cup failed on twice is given up
            if self.not_before.get(tr.track_id, 0.0) > t:
                continue  # the cup could not meet it a moment ago
            x = tr.x_at(t, self.speed)
            # The track's item of the last call, moved, while its probabilities are the same
            # array (the tracker replaces the array when it updates them).
            probs, item = self._track_items.get(tr.track_id, (None, None))
            if probs is tr.probs:
                item = item.at(x, tr.y)
            else:
                item = TrackedItem(tr.track_id, x, tr.y, tuple(tr.probs))
            made[tr.track_id] = (tr.probs, item)
            items.append(item)
        self._track_items = made
        return sure_items(items, self.config.min_class_confidence)

    def _book_unsure(self, gone: list) -> None:
        """Count the tracks among `gone` (went past the robot unpicked, or still tracked at the
        end) that the confidence rule kept from the decision manager (`left_unsure`)."""
        threshold = self.config.min_class_confidence
        self.metrics.on_left_unsure(sum(1 for tr in gone if is_unsure(tr.probs, threshold)))

    def _finished(self) -> bool:
        if any(s.robot.busy for s in self.stations):  # a pick under way is always finished
            return False
        t = self.data.time
        if t >= self.t_cap:
            return True
        if self.next_spawn < len(self.flow) or self._waiting or len(self.cell.pool.active_slots()):
            return False
        return t >= self.t_last_spawn + SETTLE_S

    def _idle_steps(self) -> int:
        """Physics steps until the next event while the robot idles."""
        t, dt = self.data.time, self.model.opt.timestep
        events = [self.next_obs, self.next_check, *(s.next_decision for s in self.stations)]
        if self.next_spawn < len(self.flow):
            events.append(float(self.flow.t_spawn[self.next_spawn]))
        if self._waiting:  # an item held back at the infeed drops as soon as it drops clear
            events.append(t)
        if self.video is not None:
            events.append(self.video.next_frame_time)
        return max(1, int(math.ceil((min(events) - t) / dt - 1e-9)))

    def _close_out(self) -> None:
        """Items still on the belt at the time cap count as missed (once)."""
        if self._closed_out:
            return
        self._closed_out = True
        self.metrics.on_warnings(self.mj_warnings.update())
        self._book_unsure(self.tracker.tracks())  # still tracked when the episode ended
        for slot in self.cell.pool.active_slots():
            self.metrics.on_missed(int(self.cell.pool.park(self.data, int(slot))))

    def status_text(self) -> str:
        """One line for the progress bar."""
        m = self.metrics
        return (
            f"t {self.data.time:6.1f} s  entered {m.n_entered}  picked {m.n_picked}  "
            f"missed {len(m.missed)}  profit {m.profit:.2f} EUR"
        )
