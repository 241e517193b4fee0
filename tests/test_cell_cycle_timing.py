"""The decision managers' cycle-time model against the pick controller's plans in physics."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from planner.motion.cycle_model import PICK_COEF, PLACE_COEF
from sim.config import EpisodeConfig
from sim.episode.cycle_timing import (
    CELL_PICK_COEF,
    CELL_PLACE_COEF,
    cycle_errors,
    fit_to_plans,
)
from sim.episode.decision_view import cell_context
from sim.episode.loop import Episode
from sim.episode.pick_control import StartedPick


def test_fit_recovers_known_calibrations():
    """Picks timed by a model with known calibrations give those calibrations back."""
    context = cell_context(0.222)
    truth = replace(context.cycle_model, pick_coef=(0.02, 1.4), place_coef=(0.09, 1.3))
    rng = np.random.default_rng(3)
    picks = []
    while len(picks) < 60:
        start = context.bins[rng.integers(3)]
        x, y = rng.uniform(-0.3, 0.2), rng.uniform(-0.3, 0.3)
        bounds = context.window.bounds(y)
        t = truth.time_to_pick(start, (x, y), context.belt_speed)
        x_meet = x + context.belt_speed * t
        if bounds is None or not bounds[0] + 0.02 < x_meet < bounds[1]:
            continue
        b = int(rng.integers(2, 5))
        place = truth.time_to_place((x_meet, y, truth.pick_z), context.bin_of(b))
        picks.append(StartedPick(tuple(start), (x, y), b, t, t + place))
    fitted = fit_to_plans(context, picks, [context.belt_speed] * len(picks))
    np.testing.assert_allclose(fitted.pick_coef, truth.pick_coef, atol=2e-3)
    np.testing.assert_allclose(fitted.place_coef, truth.place_coef, atol=2e-3)


@pytest.fixture(scope="module")
def started_picks(cell):
    """The picks the controller planned in a short busy truth episode (a seed the fit never
    saw)."""
    config = EpisodeConfig(
        seed=7, items=30, duration_s=20.0, speed_factor=1.2, planner="fifo", perception="truth"
    )
    with Episode(config, cell) as episode:
        episode.reset()
        episode.run()
        return config.belt_speed_mps, list(episode.robot.started)


def test_cell_model_times_the_physics_picks(started_picks):
    """The cell's calibrated model predicts the controller's cycle times without bias (within
    40 ms on average, 70 ms rms; fitted on other seeds: sim.evaluation.cell_cycle_fit); the
    bare-pick calibration it replaced was more than 0.1 s a pick too short."""
    speed, picks = started_picks
    assert len(picks) >= 15
    context = cell_context(speed)
    assert context.cycle_model.pick_coef == CELL_PICK_COEF
    assert context.cycle_model.place_coef == CELL_PLACE_COEF
    speeds = [speed] * len(picks)
    errors = cycle_errors(context, picks, speeds)
    assert len(errors) >= 0.9 * len(picks)
    assert abs(errors.mean()) < 0.040
    assert np.sqrt(np.mean(errors**2)) < 0.070
    bare = replace(context.cycle_model, pick_coef=PICK_COEF, place_coef=PLACE_COEF)
    assert cycle_errors(replace(context, cycle_model=bare), picks, speeds).mean() > 0.10
