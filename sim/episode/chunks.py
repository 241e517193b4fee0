"""Busy stepping in chunks: while robots play picks already planned, the physics runs step
after step with nothing between two steps but each step's own work, up to the next scheduled
event or decision.

The work of a step is what changes the next one or must be judged at once: each busy robot's
set-points (its playback's next row), the actuators' log (the energy meters integrate it in
numpy when read), the riders' belt time, and each busy cup's check (the seal's contact, the held
item's load against the seal's capacity, the release), the vacuum switched at the pick's phase
times. What the loop does besides once a step (the scheduler's due test, the idle robots'
decisions, the picks' outcomes) is done once a chunk: a chunk ends on the step at which the
earliest event or idle robot's decision falls due, by the loop's own due test on the clock
summed step by step as MuJoCo sums it (`steps_until_due_stepwise`), or earlier, on the step at
which a cup did something or a pick's chain has been played. Every result is the same to the
bit as stepping one at a time (`tests/test_chunks.py`).

A user's `"before_step"` or `"after_step"` hook sees every step: registering one makes the loop
step one at a time (`sim.episode.loop.Episode.add_hook`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import mujoco

from sim.episode.parts import is_due

MAX_CHUNK_STEPS = 1000
"""Most steps in one chunk (the item checks, every 20 ms, end most chunks long before)."""


class BusyRobot(Protocol):
    """What a chunk needs of a robot playing a pick (`sim.episode.pick_control`)."""

    def before_step(self) -> None:
        """Write the coming step's set-points."""

    def after_step(self) -> bool:
        """The step's cup work; True when the loop must look at the pick before going on."""


class StepLog(Protocol):
    """What records a step for later reading (`sim.monitors.energy.ActuatorLog`)."""

    def record(self, duration_s: float) -> None:
        """Record the step just made, which covered `duration_s` [s]."""


class BeltClock(Protocol):
    """What is owed the belt's time (`sim.cell.riding.ItemRiding`)."""

    def carry(self, duration: float) -> None:
        """The belt has run `duration` [s] more."""


def steps_until_due_stepwise(t: float, when: float, dt: float, limit: int) -> int:
    """Steps of `dt` [s] from sim time `t` [s] until something due at `when` [s] is due by
    the loop's due test (`sim.episode.scheduler.is_due`), at least 1 and at most `limit`.

    The clock is summed step by step, as `mj_step` advances `data.time`, so the step found is
    the one at which a loop testing after every step would find it due (the idle blocks'
    `sim.episode.scheduler.steps_until_due` divides instead).
    """
    for n in range(1, limit + 1):
        t += dt
        if is_due(t, when):
            return n
    return limit


def step_busy(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    robots: Sequence[BusyRobot],
    log: StepLog,
    belt: BeltClock,
    steps: int,
) -> int:
    """Step the physics up to `steps` times with each step's work (see the module docstring);
    returns the steps made (fewer when a robot's pick needs looking at).

    Args:
        model, data: The cell.
        robots: The robots playing picks, upstream first.
        log: The actuators' log, recorded after every step.
        belt: The riders' belt clock, carried on after every step.
        steps: The most steps to make (>= 1).
    """
    dt = float(model.opt.timestep)
    step, record, carry = mujoco.mj_step, log.record, belt.carry
    for done in range(1, steps + 1):
        for robot in robots:
            robot.before_step()
        step(model, data)
        record(dt)
        carry(dt)
        look = False
        for robot in robots:
            look = robot.after_step() or look  # every robot's cup, in order
        if look:
            return done
    return steps
