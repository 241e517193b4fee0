"""Hooks and scheduled events registered from outside the package: the documented way to step
an episode, with a user's after-step and before-step hooks and a periodic function."""

from __future__ import annotations

import numpy as np
import pytest

from sim import config
from sim.cell.cell import Cell
from sim.episode.loop import Episode
from sim.episode.scheduler import DUE_TOLERANCE_S, is_due, steps_until_due
from sim.errors import InvalidInput


@pytest.fixture(scope="module")
def cell() -> Cell:
    return Cell()


def test_a_users_hooks_and_periodic_function_run_across_resets(cell):
    episode = Episode(config.load(None, perception="truth", items=10, duration_s=6.0), cell)
    after, before, every = [], [], []
    episode.add_hook("after_step", lambda ep: after.append(float(ep.data.time)))
    episode.add_hook("before_step", lambda ep: before.append(float(ep.data.time)))
    episode.every(0.5, lambda ep: every.append(float(ep.data.time)))
    for seed in (3, 4):
        after.clear(), before.clear(), every.clear()
        episode.reset(seed=seed)
        picks = 0
        while episode.step_until_decision():
            picks += episode.apply(episode.choose())
        assert picks >= 5
        assert episode.metrics.n_picked >= 5
        end = float(episode.data.time)
        # Every step (or idle block) ran both hooks, in time order, to the end.
        assert len(after) == len(before) > 1000
        assert np.all(np.diff(after) > 0) and after[-1] == pytest.approx(end)
        # The periodic function: at 0, 0.5, 1.0, ... s, each at its time to the step.
        expected = np.arange(len(every)) * 0.5
        step = float(cell.model.opt.timestep)
        assert np.all(np.asarray(every) >= expected - DUE_TOLERANCE_S)
        assert np.all(np.asarray(every) - expected < step + 1e-9)
        assert len(every) == int(end / 0.5 + 1e-9) + 1
    episode.close()


def test_a_hook_reads_riders_where_the_belt_has_carried_them(cell):
    """Item poses read through the cell's accessors are never behind the belt."""
    episode = Episode(config.load(None, perception="truth", items=20, duration_s=8.0), cell)
    behind, moved = [], []

    def watch(ep):
        riders = ep.riding.riding()
        if len(riders):
            x = ep.cell.items.positions(riders)[:, 0].copy()
            behind.append(ep.riding.behind_s)
            moved.append((riders, x, float(ep.data.time)))

    episode.add_hook("after_step", watch)
    episode.reset(seed=1)
    for _ in range(3000):
        episode._step()
    assert behind and max(behind) == 0.0
    # Between two reads a rider moves at the belt's speed.
    (r0, x0, t0), (r1, x1, t1) = moved[-2], moved[-1]
    common = np.intersect1d(r0, r1)
    assert len(common)
    dx = x1[np.searchsorted(r1, common)] - x0[np.searchsorted(r0, common)]
    np.testing.assert_allclose(dx, episode.speed * (t1 - t0), atol=1e-9)
    episode.close()


@pytest.mark.parametrize("stage", ["after", "before_substep", ""])
def test_an_unknown_hook_stage_is_refused_naming_the_allowed(cell, stage):
    episode = Episode(config.load(None, perception="truth", items=5, duration_s=5.0), cell)
    with pytest.raises(InvalidInput, match="before_step | after_step"):
        episode.add_hook(stage, lambda ep: None)


@pytest.mark.parametrize("period", [0.0, -1.0, float("nan"), float("inf"), "1"])
def test_a_period_that_is_not_positive_is_refused(cell, period):
    episode = Episode(config.load(None, perception="truth", items=5, duration_s=5.0), cell)
    with pytest.raises(InvalidInput, match="period_s"):
        episode.every(period, lambda ep: None)


@pytest.mark.parametrize("period", [0.5, 0.37, 0.02])
def test_events_fire_at_the_first_step_they_are_due(cell, period):
    """The idle stepping's blocks end where the loop's own due test first holds: no event
    fires a step late (`scheduler.steps_until_due`, `scheduler.is_due`)."""
    episode = Episode(config.load(None, perception="truth", items=15, duration_s=8.0), cell)
    fired = []
    event = episode.every(period, lambda ep: fired.append((float(ep.data.time), event.next_s)))
    episode.reset(seed=0)
    episode.run()
    dt = float(cell.model.opt.timestep)
    assert len(fired) > 10
    for t, when in fired:
        assert is_due(t, when)
        if when > 0.0:  # due at the start: fired after the first step
            assert not is_due(t - dt, when), (t, when)


def test_steps_until_due_is_the_loops_due_test():
    rng = np.random.default_rng(7)
    dt = 0.001
    for _ in range(500):
        t = float(rng.integers(0, 100_000)) * dt + float(rng.normal(0.0, 1e-11))
        when = t + float(rng.uniform(0.0, 0.6))
        n = steps_until_due(t, when, dt)
        clock = t
        for _ in range(n):
            clock += dt  # the clock MuJoCo keeps: a sum of steps
        assert is_due(clock, when)
        if n > 1:
            assert not is_due(clock - dt, when)


def test_the_cameras_rows_follow_the_belts_travel():
    """A `BeltRowEvent` is due when a `PeriodicEvent` of its period is while the belt runs at
    its set speed, never while it stands, every two periods at half speed."""
    from sim.cell.conveyor import BeltEncoder
    from sim.episode.scheduler import BeltRowEvent, PeriodicEvent

    fired: list[float] = []
    encoder = BeltEncoder(0.185)
    rows = BeltRowEvent(0.5, lambda parts: fired.append(parts), encoder)
    periodic = PeriodicEvent(0.5, lambda parts: None)
    for k in range(4):
        t = 0.5 * k
        assert rows.due(t) and periodic.due(t) and rows.next_time(t) == periodic.next_time(t)
        rows.fire(t)  # type: ignore[arg-type]
        periodic.fire(None)  # type: ignore[arg-type]
    encoder.run_at(1.9, 0.0)  # stopped 0.1 s before the row of 2 s
    assert rows.next_time(1.9) is None and not rows.due(100.0)
    encoder.run_at(10.0, 0.0925)  # on at half speed: 0.1 s of the set speed's clock left
    assert rows.next_time(10.0) == pytest.approx(10.2) and not rows.due(10.19)
    rows.fire(10.2)  # type: ignore[arg-type]
    assert rows.next_time(10.2) == pytest.approx(11.2)
    assert fired == [0.0, 0.5, 1.0, 1.5, 10.2]
