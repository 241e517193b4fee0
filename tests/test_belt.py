"""The belt carries every item type at its speed, without rolling or sliding off (cell scene)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from sim.cell.conveyor import (
    SPEED_FACTORS,
    SPEED_MAX,
    SPEED_MIN,
    Belt,
    check_speed,
    speed_for_factor,
)
from sim.cell.item_pool import ItemPool
from sim.errors import InvalidInput
from sim.flow.catalogue import load_catalogue
from tests.utils import scene_at_home

CATALOGUE = load_catalogue()
SPEED_TOLERANCE = 0.02  # relative, after 1 s on the belt
LATERAL_DRIFT = 0.05  # [m]: a bottle dropped askew rolls up to 3.5 cm before it settles
SPIN_TOLERANCE = 0.05  # [rad/s]
HEIGHT_TOLERANCE = 0.001  # [m] around the resting height: not tipped, not rolled over


def cell():
    return scene_at_home()


def test_speed_factors_and_range():
    assert speed_for_factor(1) == pytest.approx(0.185)
    assert speed_for_factor(1.2) == pytest.approx(0.222)
    assert speed_for_factor(1.5) == pytest.approx(0.2775)
    assert check_speed(SPEED_MIN) == SPEED_MIN and check_speed(SPEED_MAX) == SPEED_MAX
    for bad in (0.1, 0.134, 0.279, -0.2, math.nan, "fast"):
        with pytest.raises(InvalidInput, match=r"belt_speed: allowed 0\.135 to 0\.277 m/s"):
            check_speed(bad)
    with pytest.raises(InvalidInput, match="speed_factor"):
        speed_for_factor(2.0)


def test_set_speed_writes_surface_velocity_and_refuses_out_of_range():
    model, _ = cell()
    belt = Belt(model)
    belt.set_speed(0.2)
    assert model.geom_surfacevel[belt.geom_id].tolist() == [0.2, 0, 0, 0, 0, 0]
    with pytest.raises(InvalidInput):
        belt.set_speed(0.3)
    assert belt.speed == 0.2  # a refused speed leaves the belt as it was
    geometry = belt.geometry
    assert (geometry.x_infeed, geometry.x_discharge) == pytest.approx((-3.0, 1.5))
    assert geometry.y_half == pytest.approx(0.4) and geometry.top_z == pytest.approx(0.0)


@pytest.mark.parametrize("factor", SPEED_FACTORS)
@pytest.mark.parametrize("yaw", [0.0, math.pi / 4, math.pi / 2])
def test_every_item_type_rides_at_belt_speed(factor, yaw):
    """Each type dropped at rest moves at the belt's speed within 2 % after 1 s, stays put."""
    model, data = cell()
    belt = Belt(model)
    speed = belt.set_factor(factor)
    pool = ItemPool(model, CATALOGUE, belt)
    start = {}
    for k, item_type in enumerate(CATALOGUE.types):
        row, lane = divmod(k, 2)
        half_y = float(item_type.half_extents(yaw)[1])
        y = (1 if lane else -1) * (belt.geometry.y_half - 0.01 - half_y)
        slot = pool.spawn(data, k, k, -2.8 + 0.33 * row, y, yaw, CATALOGUE.rgba[k % 6])
        start[slot] = y
    steps = int(round(1.0 / model.opt.timestep))
    for _ in range(steps):
        mujoco.mj_step(model, data)
    assert not any(w.number for w in data.warning)  # no instability, no overflow
    for slot, y0 in start.items():
        item_type = pool.item_type(slot)
        dof = pool.dof_adr[slot]
        vel = data.qvel[dof : dof + 6]
        pos = pool.position(data, slot)
        where = f"{item_type.name} at x{factor}, yaw {yaw:.2f}"
        assert abs(vel[0] / speed - 1.0) < SPEED_TOLERANCE, where
        assert abs(pos[1] - y0) < LATERAL_DRIFT, where
        assert abs(vel[1]) < SPEED_TOLERANCE * speed, where
        assert np.linalg.norm(vel[3:]) < SPIN_TOLERANCE, where
        assert abs(pos[2] - item_type.rest_height) < HEIGHT_TOLERANCE, where
        assert belt.geometry.on_belt(pos[:2]), where


def test_the_encoder_reads_the_belts_travel_through_a_stop_and_a_slowdown():
    """Without a change the encoder's clock is the sim time itself; a stop holds its travel,
    a slowdown runs it at the new speed, and `time_at` inverts the clock at the speed now."""
    model, _ = cell()
    belt = Belt(model)
    belt.set_speed(0.185)
    encoder = belt.encoder
    assert encoder.travel(2.0) == 0.185 * 2.0 and encoder.clock(2.0) == 2.0
    assert encoder.time_at(2.5) == 2.5
    belt.run_at(0.0, 4.0)  # stopped at 4 s
    assert model.geom_surfacevel[belt.geom_id, 0] == 0.0
    assert encoder.travel(9.0) == pytest.approx(0.74) and encoder.clock(9.0) == pytest.approx(4.0)
    assert encoder.time_at(4.5) is None  # the next row never comes while it stands
    belt.run_at(0.0925, 10.0)  # on at half speed at 10 s
    assert encoder.clock(12.0) == pytest.approx(5.0)
    assert encoder.time_at(5.5) == pytest.approx(13.0)
    belt.set_speed(0.2)  # an episode's start: the encoder from 0 again
    assert not encoder.changed and encoder.travel(1.0) == 0.2
