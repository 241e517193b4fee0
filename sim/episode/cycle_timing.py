"""The decision managers' cycle-time model of the cell, calibrated on the pick controller's plans.

`planner.motion.cycle_model.CycleTimeModel` times a pick and a place with a closed form and an
affine calibration fitted to ruckig plans of a bare pick (25 mm approach and lift, the nominal
drop point). The cell's pick controller (`sim.episode.pick_control`) plans more than that: the
held item's bottom lifted to the clear height over the rails and the tallest standing item
(about 0.14 m), the drop point raised for tall items, axis 4 turned to lay the item along the
bin, the approach raised over a neighbour, and `RELEASE_CLEAR_S` of stillness after each
release. With the bare-pick calibration the planners saw the physics' robot a third faster
than it is (0.17 s a pick too short: the "kinematic belt faster than physics" of
docs/results.md), so in physics every plan over several picks counted on items that were gone
by then.

`CELL_PICK_COEF` and `CELL_PLACE_COEF` are the same closed form fitted to the plans the
controller made in physics episodes on training seeds (every decision manager, the thesis's
three belt speeds, busy and saturated belts): `python -m sim.evaluation.cell_cycle_fit`,
which also prints the errors on held-out episodes. Every decision manager of an episode and the
planner-level benchmark's kinematic belt use it (`cell_cycle_model`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from planner.decision.candidates import intercept
from planner.decision.interface import DecisionContext
from planner.motion.cycle_model import CycleTimeModel, fit_affine
from planner.motion.limits import MotionLimits
from sim.episode.pick_control import StartedPick

CELL_PICK_COEF = (-0.0153, 1.6226)
"""(c0 [s], c1) of the start-to-contact time on the cell's plans."""
CELL_PLACE_COEF = (0.1129, 1.4627)
"""(c0 [s], c1) of the contact-to-move-on time on the cell's plans (seal and release times
excluded, the release clearance included in c0)."""


def cell_cycle_model(
    limits: MotionLimits,
    pick_z: float,
    lift_height: float,
    seal_time: float,
    release_time: float,
) -> CycleTimeModel:
    """The closed-form model with the cell's lift and vacuum times and its calibration."""
    return CycleTimeModel(
        limits=limits,
        pick_z=pick_z,
        lift_height=lift_height,
        seal_time=seal_time,
        release_time=release_time,
        pick_coef=CELL_PICK_COEF,
        place_coef=CELL_PLACE_COEF,
    )


ENTRY_MARGIN_M = 0.01
"""Picks met closer than this downstream of the window's entry are left out of the pick fit:
the cup waited there for the item, a time the closed form does not time [m]."""


def fit_to_plans(
    context: DecisionContext, picks: Sequence[StartedPick], speeds: Sequence[float]
) -> CycleTimeModel:
    """The context's cycle model with both calibrations fitted by least squares to the
    controller's `picks` (each at its belt speed [m/s] in `speeds`)."""
    model = context.cycle_model
    assert isinstance(model, CycleTimeModel), "fitted: the closed form (`cell_cycle_model`)"
    pick_rows, place_rows = [], []
    for p, v in zip(picks, speeds, strict=True):
        x, y = p.item_xy
        meet = (x + v * p.contact_time, y, model.pick_z)
        bounds = context.window.bounds(y)
        if bounds is not None and meet[0] > bounds[0] + ENTRY_MARGIN_M:
            pick_rows.append((model.pick_raw(p.start_xyz, meet), p.contact_time))
        place = model.place_raw(meet, context.bin_of(p.bin_class))
        place_rows.append((place, p.cycle_time - p.contact_time))
    pick_a, place_a = np.array(pick_rows), np.array(place_rows)
    fixed = model.seal_time + model.release_time
    return replace(
        model,
        pick_coef=fit_affine(pick_a[:, 0], pick_a[:, 1]),
        place_coef=fit_affine(place_a[:, 0], place_a[:, 1] - fixed),
    )


def cycle_errors(
    context: DecisionContext, picks: Sequence[StartedPick], speeds: Sequence[float]
) -> np.ndarray:
    """Planned minus predicted cycle time of each pick [s], the prediction made as the
    decision managers make it (`planner.decision.candidates.intercept`, waits at the window's
    entry included); picks the model calls lost are left out."""
    errors = []
    for p, v in zip(picks, speeds, strict=True):
        ctx = replace(context, belt_speed=v) if v != context.belt_speed else context
        hit = intercept(ctx, p.start_xyz, 0.0, p.item_xy[0], p.item_xy[1])
        if hit is None:
            continue
        meet, x_meet, _waits = hit
        bin_xyz = ctx.bin_of(p.bin_class)
        model = ctx.cycle_model
        assert isinstance(model, CycleTimeModel), "the closed form (`cell_cycle_model`)"
        meet_xyz = (x_meet, p.item_xy[1], model.pick_z)
        place = model.time_to_place(meet_xyz, bin_xyz)
        errors.append(p.cycle_time - (meet + place))
    return np.array(errors)
