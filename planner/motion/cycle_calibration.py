"""Ruckig-planned picks and places that calibrate and test `planner.motion.cycle_model`.

Each sample: the robot at rest at a bin's drop point or a random point of the workspace, an
item at a random place of the belt inside the window riding at a thesis belt speed, the pick
intercepted and planned with ruckig (`planner.motion.intercept.intercept_item`) and placed in a
random bin. The model's closed-form times are recorded beside the planned ones.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from planner.motion.belt_speeds import THESIS_SPEEDS_MPS
from planner.motion.cycle_model import CycleTimeModel, fit_affine
from planner.motion.intercept import intercept_item
from planner.motion.pick_cycle import PickPlaceConfig
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from planner.motion.trajectory import State

BELT_SPEEDS = THESIS_SPEEDS_MPS
"""The thesis's belt speeds x1, x1.2, x1.5 [m/s]."""


@dataclass(frozen=True)
class Samples:
    """Planned and modelled times, one row per sample [s].

    Attributes:
        pick_planned: Ruckig meeting times.
        pick_raw: Closed-form times to the planned meeting point.
        place_planned: Ruckig contact-to-release-end times.
        place_raw: Closed-form transfer times.
        starts: (n, 3) start points; items: (n, 2) item positions; speeds: (n,) belt speeds;
        bins: (n, 3) drop points.
    """

    pick_planned: np.ndarray
    pick_raw: np.ndarray
    place_planned: np.ndarray
    place_raw: np.ndarray
    starts: np.ndarray
    items: np.ndarray
    speeds: np.ndarray
    bins: np.ndarray


def draw_samples(
    generator: RuckigTrajectoryGenerator,
    model: CycleTimeModel,
    bins: Sequence[Sequence[float]],
    rng: np.random.Generator,
    n: int,
    config: PickPlaceConfig | None = None,
) -> Samples:
    """`n` feasible random picks and places planned with ruckig (refused items are redrawn),
    with the pick configuration `config` (heights, times; the default when None)."""
    rows: list[tuple] = []
    while len(rows) < n:
        if rng.random() < 0.5:
            start = np.asarray(bins[int(rng.integers(len(bins)))], dtype=float)
        else:
            start = np.array(
                [rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4), rng.uniform(0.05, 0.2)]
            )
        item = np.array([rng.uniform(-0.45, 0.4), rng.uniform(-0.35, 0.35)])
        speed = float(rng.choice(BELT_SPEEDS))
        drop = np.asarray(bins[int(rng.integers(len(bins)))], dtype=float)
        try:
            hit = intercept_item(
                State.at_rest(start), item, speed, drop, generator, model.pick_z, config
            )
        except ValueError:  # start point outside the workspace
            continue
        if not hit.feasible:
            continue
        plan = hit.plan
        assert plan is not None  # planned with the intercept (with_plan)
        rows.append(
            (
                hit.meet_time,
                model.pick_raw(start, hit.pick_xyz),
                plan.duration - plan.contact_time,
                model.place_raw(hit.pick_xyz, drop),
                start,
                item,
                speed,
                drop,
            )
        )
    cols = list(zip(*rows, strict=True))
    return Samples(*(np.array(c) for c in cols))


def fitted_model(model: CycleTimeModel, samples: Samples) -> CycleTimeModel:
    """`model` with both calibrations fitted to `samples` by least squares."""
    fixed = model.seal_time + model.release_time
    return replace(
        model,
        pick_coef=fit_affine(samples.pick_raw, samples.pick_planned),
        place_coef=fit_affine(samples.place_raw, samples.place_planned - fixed),
    )
