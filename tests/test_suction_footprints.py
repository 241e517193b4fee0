"""Where on an item the cup seals: inside each footprint's outline by the edge margin, not off it.

The cup seals only where its axis meets the item's footprint at least `edge_margin` x the cup
radius (0.5 x 30 mm = 15 mm) inside the outline (`SuctionCup._lip_on_item`). Footprints are
rectangles (boxes, lying cans), discs (standing cans and pots) and stadiums (lying bottles,
straight part of half-length a with round ends of radius r). Each case puts an item under the
resting cup of the cell's scene, its top 3 mm into the lip as the pick controller presses it
(the lip touching it is checked), at a known offset of the cup's axis in the item's body frame,
opens the vacuum and advances the clock by the seal time: the cup seals or not. The offsets
straddle each outline by 1 mm, and the corners of a disc's bounding square and of a stadium's
bounding rectangle, which lie outside their outlines, must not seal.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from sim.cell.conveyor import Belt
from sim.cell.item_pool import ItemPool
from sim.cell.suction import CUP_SITE, SuctionCup
from sim.episode.pick_control import PRESS_DEPTH_M
from sim.flow.catalogue import load_catalogue
from tests.utils import scene_at_home

CATALOGUE = load_catalogue()
STEP = 0.001  # [m] offsets this far inside / outside an outline


@pytest.fixture(scope="module")
def rig():
    """(model, data, pool) of the cell's scene, robot at home, no item on stage."""
    model, data = scene_at_home()
    pool = ItemPool(model, CATALOGUE, Belt(model))
    return model, data, pool


def edge_limit(model, pool) -> float:
    """How far inside an outline the cup's axis must be [m]: edge_margin x cup radius."""
    cup = SuctionCup(model, pool)
    return cup.config.edge_margin * cup.radius


def seals_at(rig, name: str, local_xy, yaw: float = 0.0) -> bool:
    """Whether the cup seals on item type `name` when its axis meets the item at `local_xy`
    [m] in the item's body frame (item heading `yaw` [rad])."""
    model, data, pool = rig
    for slot in pool.active_slots():
        pool.park(data, int(slot))
    cup = SuctionCup(model, pool)
    mujoco.mj_forward(model, data)
    axis = data.site(CUP_SITE).xpos.copy()
    lip = model.geom(cup.geom_id)
    lip_bottom = float(data.geom_xpos[cup.geom_id][2] - lip.size[1])
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = local_xy
    centre = axis[:2] - np.array([c * dx - s * dy, s * dx + c * dy])
    k = CATALOGUE.index(name)
    item_type = CATALOGUE.types[k]
    slot = pool.spawn(data, 0, k, centre[0], centre[1], yaw, CATALOGUE.colour_rgba("blue"))
    top = item_type.rest_height  # the item's top above its centre, as it rests
    data.qpos[pool.qpos_adr[slot] + 2] = lip_bottom + PRESS_DEPTH_M - top
    mujoco.mj_forward(model, data)
    pairs = data.contact.geom[: data.ncon]
    touching = np.any(
        (pairs == cup.geom_id).any(axis=1) & (pairs == pool.geom_id(slot)).any(axis=1)
    )
    assert touching, (name, local_xy, "the lip does not touch the item")
    body = pool.body_ids[slot]
    local = data.xmat[body].reshape(3, 3).T @ (axis - data.xpos[body])
    np.testing.assert_allclose(local[:2], local_xy, atol=1e-9)
    cup.vacuum_on()
    data.time = 1.0
    cup.update(data)
    data.time = 1.0 + cup.config.seal_time
    events = cup.update(data)
    data.time = 1.0 + 2 * cup.config.seal_time
    events += cup.update(data)
    kinds = [e.kind for e in events]
    assert kinds in ([], ["sealed"]), kinds
    pool.park(data, slot)
    return kinds == ["sealed"]


def test_the_edge_margin_is_15_mm(rig):
    model, _, pool = rig
    assert edge_limit(model, pool) == pytest.approx(0.015, abs=1e-12)


@pytest.mark.parametrize("name, yaw", [("can_330_standing", 0.0), ("yoghurt_pot", 0.7)])
def test_disc_seals_inside_its_circle_and_not_at_its_bounding_square_corners(rig, name, yaw):
    kind, radius, _ = CATALOGUE.types[CATALOGUE.index(name)].footprint
    assert kind == "disc"
    limit = radius - edge_limit(rig[0], rig[2])  # 18 mm (can), 20 mm (pot) from the centre
    assert seals_at(rig, name, (0.0, 0.0), yaw)
    for angle in np.linspace(0.0, 2 * math.pi, 8, endpoint=False):
        u = np.array([math.cos(angle), math.sin(angle)])
        assert seals_at(rig, name, (limit - STEP) * u, yaw), (name, angle)
        assert not seals_at(rig, name, (limit + STEP) * u, yaw), (name, angle)
    # Inside the bounding square of the sealing circle but outside the circle itself.
    corner = limit - STEP
    for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
        assert not seals_at(rig, name, (sx * corner, sy * corner), yaw), (name, sx, sy)
        assert not seals_at(rig, name, (sx * 0.75 * limit, sy * 0.75 * limit), yaw)
        assert seals_at(rig, name, (sx * 0.68 * limit, sy * 0.68 * limit), yaw)


@pytest.mark.parametrize("name, yaw", [("pet_bottle_0l5", 0.0), ("hdpe_bottle_1l", 1.1)])
def test_stadium_seals_along_its_body_and_round_ends_only(rig, name, yaw):
    kind, half, radius = CATALOGUE.types[CATALOGUE.index(name)].footprint
    assert kind == "stadium"
    limit = radius - edge_limit(rig[0], rig[2])  # 17.5 mm (0.5 l), 30 mm (1 l)
    assert seals_at(rig, name, (0.0, 0.0), yaw)
    for x in (0.0, 0.5 * half, half):  # along the straight part
        for sign in (1, -1):
            assert seals_at(rig, name, (sign * x, limit - STEP), yaw), (name, x)
            assert not seals_at(rig, name, (sign * x, -(limit + STEP)), yaw), (name, x)
    for sign in (1, -1):  # the round ends, on the axis
        assert seals_at(rig, name, (sign * (half + limit - STEP), 0.0), yaw)
        assert not seals_at(rig, name, (sign * (half + limit + STEP), 0.0), yaw)
    # Around a round end, 45 degrees off the axis: in the circle, then just out of it, then the
    # corner of the bounding rectangle (inside the rectangle, outside the stadium).
    d = (limit - STEP) / math.sqrt(2)
    out = (limit + STEP) / math.sqrt(2)
    corner = limit - STEP
    for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
        assert seals_at(rig, name, (sx * (half + d), sy * d), yaw), (name, sx, sy)
        assert not seals_at(rig, name, (sx * (half + out), sy * out), yaw), (name, sx, sy)
        assert not seals_at(rig, name, (sx * (half + corner), sy * corner), yaw), (name, sx, sy)


@pytest.mark.parametrize(
    "name, yaw", [("carton_box_small", 0.0), ("foil_tray", 2.0), ("can_330_lying", 0.4)]
)
def test_rectangle_seals_up_to_its_corners(rig, name, yaw):
    # The contrast: a rectangle's sealing region is itself a rectangle, corners included.
    kind, hx, hy = CATALOGUE.types[CATALOGUE.index(name)].footprint
    assert kind == "rect"
    margin = edge_limit(rig[0], rig[2])
    lx, ly = hx - margin, hy - margin
    for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
        assert seals_at(rig, name, (sx * (lx - STEP), sy * (ly - STEP)), yaw), (name, sx, sy)
        assert not seals_at(rig, name, (sx * (lx + STEP), sy * (ly - STEP)), yaw)
        assert not seals_at(rig, name, (sx * (lx - STEP), sy * (ly + STEP)), yaw)
