"""The loop of one episode: every stage called at its time, at the physics time step.

See `sim.episode` for the data flow. While the robot idles the physics is stepped in blocks up
to the next event (a drop, an observation, a decision, a bookkeeping check, a video frame);
while it moves, one step per control period (the executor calls `Episode.tick` between its
steps). The episode ends when every item has been dropped and left the belt (picked, missed,
dropped) and the robot is idle.
"""

from __future__ import annotations

import math
import time

import mujoco
import numpy as np

from planner.cycle_model import CycleTimeModel
from planner.decision import DecisionContext, RobotState, TrackedItem
from planner.registry import make_planner
from sim.belt_riding import ItemRiding
from sim.bins import BIN_CLASSES, Bins
from sim.cell import PICK_Z_NOMINAL, Cell
from sim.config import EpisodeConfig
from sim.episode_perception import CAMERA_SIZE, CameraPerception, TruthPerception
from sim.episode_robot import PRESS_DEPTH_M, PickController
from sim.flow import generate_flow
from sim.flow_config import X_INFEED, FlowConfig
from sim.metrics import EpisodeMetrics, PickRecord
from sim.tracking import Tracker
from sim.video import overlay_of

DECIDE_PERIOD_S = 0.02
"""How often an idle robot asks the decision manager again [s]."""
MAX_LEAD_S = 1.0
"""A pick is started only if the cup meets the item within this time; an item further
upstream is waited for and decided on again (its position is fresher by then) [s]."""
WAIT_STEP_S = 0.25
"""Longest wait before deciding again on an item still upstream [s]."""
MAX_FAILURES = 2
"""Attempts after which truth mode gives an item up (it is re-detected every period)."""
CHECK_PERIOD_S = 0.02
"""How often items leaving the belt, landing in bins or falling are looked for [s]."""
BELOW_BELT_Z = -0.1
"""An item whose centre is this far below the belt surface has left it [m]."""
DISCARD_MARGIN_M = 0.15
"""An item this far past the reachable window's downstream edge is out of the robot's reach
(the cup's radius and the item's half length included) [m]."""
SETTLE_S = 2.0
"""Time after the last item left before the episode may end (falls into bins) [s]."""
_OBJECTIVES = {"value_over_distance": "v/d", "value_only": "d=1", "distance_only": "v=1"}


def make_decision_manager(config: EpisodeConfig):
    """The configured planner (Q-learning parameters from the config)."""
    if config.planner == "qlearning":
        q = config.qlearning
        return make_planner(
            "qlearning",
            gamma=q.gamma,
            iterations=q.iterations,
            batch_rows=q.batch_rows,
            row_period_s=config.observation_period_s,
            objective=_OBJECTIVES[q.objective],
        )
    return make_planner(config.planner)


class Episode:
    """State of one running episode on a `Cell` (see the module docstring)."""

    def __init__(self, config: EpisodeConfig, cell: Cell, video=None, progress=None):
        self.config, self.cell, self.video, self.progress = config, cell, video, progress
        self.model, self.data = cell.model, cell.data
        self.speed = config.belt_speed_mps
        cell.reset(self.speed)
        flow_config = FlowConfig(
            n_items=config.items,
            duration_s=config.duration_s,
            speed_factor=config.speed_factor,
            seed=config.seed,
            observation_period_s=config.observation_period_s,
        )
        self.flow = generate_flow(flow_config, cell.catalogue, cell.pool.size)
        self.t_last_spawn = float(self.flow.t_spawn[-1]) if len(self.flow) else 0.0
        self.x_discard = float(np.nanmax(cell.window.x_exit)) + DISCARD_MARGIN_M
        # When the last item has passed the robot (the end of a normal episode) and a cap.
        self.t_end = self.t_last_spawn + (self.x_discard - X_INFEED) / self.speed + SETTLE_S
        self.t_cap = self.t_end + 10.0
        self.metrics = EpisodeMetrics(config.values.by_class())
        self.tracker = Tracker(self.speed)
        self.planner = make_decision_manager(config)
        self.planner.reset()
        pauses = config.robot
        self.robot = PickController(cell, self.speed, pauses.pick_pause_s, pauses.place_pause_s)
        self.bins = Bins(self.model, self.data, cell.pool)
        self.riding = ItemRiding(
            self.model, cell.pool, cell.wake_x, enabled=config.item_riding == "settled"
        )
        limits = cell.limits
        self.context = DecisionContext(
            belt_speed=self.speed,
            cycle_model=CycleTimeModel(
                limits=limits,
                pick_z=PICK_Z_NOMINAL,
                # The lift the robot makes: the held item's bottom to the clear height.
                lift_height=self.robot.clear_z + PRESS_DEPTH_M,
                seal_time=self.robot.config.seal_time,
                release_time=self.robot.config.release_time,
            ),
            window=cell.window,
            bins=cell.bins_tuple(),
            values=(config.values.paper, config.values.plastic, config.values.aluminium),
        )
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
                camera=cell.belt_camera(CAMERA_SIZE),
            )
        # The thesis discards an item once it passes the robot's working space; parking it there
        # (rather than at the belt's end) also spares the physics the items nobody can reach.
        self.next_spawn = 0
        self.next_obs = 0.0
        self.next_check = 0.0
        self.next_decision = 0.0
        self.current_pick = None  # the track being picked (shown in the video)
        self.failures: dict[int, int] = {}  # failed attempts per true item id (truth mode)
        self.timings = dict.fromkeys(
            ("physics", "perception", "decision", "planning", "video"), 0.0
        )
        self.decisions = 0
        self.latencies: dict[str, list[float]] = {"perception": [], "decision": [], "plan": []}

    # ----- per-step bookkeeping (also called by the executor between its steps) ---------------

    def tick(self) -> None:
        """Everything due at the current sim time except decisions."""
        t = self.data.time
        if self.next_spawn < len(self.flow) and self.flow.t_spawn[self.next_spawn] <= t:
            self._spawn()
        if t + 1e-9 >= self.next_obs:
            self._observe(t)
            self.next_obs += self.config.observation_period_s
        if t + 1e-9 >= self.next_check:
            self._check_items(t)
            self.next_check += CHECK_PERIOD_S
        if self.video is not None and self.video.due(t):
            t0 = time.perf_counter()
            self.video.capture(self.data, overlay_of(self, t))
            self.timings["video"] += time.perf_counter() - t0

    def _spawn(self) -> None:
        """Hand the due items over to the belt (at its speed, as from an infeed conveyor)."""
        first = self.next_spawn
        self.next_spawn = self.cell.pool.feed(self.data, self.flow, first)
        mujoco.mj_kinematics(self.model, self.data)  # poses of the new items for the checks
        for i in range(first, self.next_spawn):
            self.metrics.on_entered(i, int(self.flow.class_id[i]))

    def _observe(self, t: float) -> None:
        t0 = time.perf_counter()
        mujoco.mj_kinematics(self.model, self.data)
        self.tracker.update(self.perception.observe(t))
        dt = time.perf_counter() - t0
        self.timings["perception"] += dt
        self.latencies["perception"].append(dt)

    def _check_items(self, t: float) -> None:
        pool, data = self.cell.pool, self.data
        held = self.robot.suction.held_slot
        for slot in pool.active_slots():
            if slot == held:
                continue
            pos = data.xpos[pool.body_ids[slot]]
            if pos[0] > self.x_discard and pos[2] > BELOW_BELT_Z:  # passed the robot: discarded
                item_id = pool.park(data, int(slot))
                self.metrics.on_missed(item_id)
                self.tracker.remove_true(item_id)
        for item_id in pool.park_missed(data):  # past the belt's end (e.g. pushed along)
            self.metrics.on_missed(item_id)
            self.tracker.remove_true(item_id)
        for landing in self.bins.update(data, held):
            if landing.bin is None:
                self.metrics.on_dropped(landing.item_id)
            else:
                bin_class = BIN_CLASSES.index(landing.bin) + 2
                self.metrics.on_binned(landing.item_id, landing.true_class, bin_class)
            self.tracker.remove_true(landing.item_id)
        self.tracker.prune(t, self.x_discard)
        self.riding.update(data, held)

    # ----- decisions and picks ----------------------------------------------------------------

    def _tracked_items(self, t: float) -> list[TrackedItem]:
        items = []
        for tr in self.tracker.tracks():
            if self.failures.get(tr.true_id, 0) >= MAX_FAILURES:
                continue  # truth mode: an item the cup failed on twice is given up
            items.append(TrackedItem(tr.track_id, tr.x_at(t, self.speed), tr.y, tuple(tr.probs)))
        return items

    def _decide_and_pick(self, t: float) -> bool:
        """Ask the planner; if it chooses an item that can be met, pick it. True if picked."""
        items = self._tracked_items(t)
        if not items:
            return False
        t0 = time.perf_counter()
        robot = RobotState(tuple(self.robot.rest), t)
        choice = self.planner.choose(items, robot, self.context)
        t1 = time.perf_counter()
        self.timings["decision"] += t1 - t0
        self.latencies["decision"].append(t1 - t0)
        self.decisions += 1
        if choice is None:
            return False
        if choice.meet_time - t > MAX_LEAD_S:
            # Far upstream: wait where we are and decide again with fresher positions.
            self.next_decision = t + min(choice.meet_time - t - MAX_LEAD_S, WAIT_STEP_S)
            return False
        track = self.tracker.get(choice.item_id)
        x = track.x_at(t, self.speed)
        intercept = self.robot.plan(x, track.y, choice.bin_class)
        self.timings["planning"] += time.perf_counter() - t1
        self.latencies["plan"].append(time.perf_counter() - t1)
        if not intercept.feasible:
            self.tracker.remove(track.track_id)  # cannot be met: let it go
            return False
        if intercept.meet_time > MAX_LEAD_S + WAIT_STEP_S:
            self.next_decision = t + WAIT_STEP_S  # the cycle model was optimistic: wait
            return False
        self.current_pick = track
        self.tracker.remove(track.track_id)
        outcome = self.robot.execute(intercept, self.tick)
        self.current_pick = None
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
            )
        )
        return True

    # ----- the loop -----------------------------------------------------------------------------

    def _finished(self) -> bool:
        t = self.data.time
        if t >= self.t_cap:
            return True
        if self.next_spawn < len(self.flow) or len(self.cell.pool.active_slots()):
            return False
        return t >= self.t_last_spawn + SETTLE_S

    def _idle_steps(self) -> int:
        """Physics steps until the next event while the robot idles."""
        t, dt = self.data.time, self.model.opt.timestep
        events = [self.next_obs, self.next_check, self.next_decision]
        if self.next_spawn < len(self.flow):
            events.append(float(self.flow.t_spawn[self.next_spawn]))
        if self.video is not None:
            events.append(self.video._next_t)
        return max(1, int(math.ceil((min(events) - t) / dt - 1e-9)))

    def run(self) -> None:
        """Simulate until the episode ends."""
        data, model = self.data, self.model
        last_report = -1.0
        while not self._finished():
            t = data.time
            if t + 1e-9 >= self.next_decision:
                self.next_decision = t + DECIDE_PERIOD_S
                picked = self._decide_and_pick(t)
                if picked:
                    self.next_decision = data.time
                if picked:
                    continue
            mujoco.mj_step(model, data, nstep=self._idle_steps())
            self.tick()
            if self.progress is not None and data.time - last_report >= 1.0:
                last_report = data.time
                self.progress(min(data.time / self.t_end, 1.0), self.status_text())
        for slot in self.cell.pool.active_slots():  # still on the belt at the time cap
            self.metrics.on_missed(int(self.cell.pool.park(data, int(slot))))

    def status_text(self) -> str:
        """One line for the progress bar."""
        m = self.metrics
        return (
            f"t {self.data.time:6.1f} s  entered {m.n_entered}  picked {m.n_picked}  "
            f"missed {len(m.missed)}  profit {m.profit:.2f} EUR"
        )
