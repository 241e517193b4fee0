"""Items thrown off the belt: how they are judged, and picks that leave the neighbours alone.

The cup flies over a standing can on its way down to a flat board (the plan planned without
the neighbours would strike the can at over 5 m/s); a board with a can on its edge is not
picked (lifting it would fling the can), while the top sheet of a pile is; a pick whose seal
fails leaves both its item and the neighbour beside it on the belt; a held bottle lifts
straight up from beside the can lying 5 mm upstream of it, which rides on at the belt's speed.
"""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from perception.codes import ALUMINIUM, PAPER, PLASTIC
from planner.motion.clearance import Obstacle, footprint_distances, outline_points, path_conflicts
from planner.motion.intercept import intercept_item
from planner.motion.trajectory import State
from sim.cell.cell import Cell
from sim.cell.held_slots import held_slots
from sim.cell.suction import SuctionConfig, SuctionCup
from sim.episode.pick_control import (
    ON_SHEET_PRESS_M,
    PRESS_DEPTH_M,
    SHEET_TOP_M,
    TOUCH_GAP_M,
    PickController,
)
from sim.monitors.thrown import THROW_SPEED_MPS, ThrowWatch, rail_outer_y

SPEED = 0.185


@pytest.fixture(scope="module")
def cell() -> Cell:
    """A cell of this module's own (its items are spawned by hand)."""
    return Cell()


def _spawn(cell: Cell, item_id: int, name: str, x: float, y: float, speed: float = SPEED) -> int:
    """Drop a catalogue item at (x, y) [m], heading along the belt, at the belt's `speed`."""
    k = [t.name for t in cell.catalogue.types].index(name)
    return cell.pool.spawn(cell.data, item_id, k, x, y, 0.0, (0.5, 0.5, 0.5, 1), speed)


def _speed(cell: Cell, slot: int) -> float:
    dof = cell.pool.dof_adr[slot]
    return float(np.linalg.norm(cell.data.qvel[dof : dof + 3]))


def _play(robot: PickController, intercept, watched: list[int]):
    """Play a pick as the episode's loop does; returns (outcome, peak speed of each watched
    slot [m/s], the items thrown off as the episode judges them every 20 ms)."""
    cell = robot.cell
    watch = ThrowWatch(cell.model, cell.pool)
    peak = dict.fromkeys(watched, 0.0)
    throws = []
    robot.start(intercept)
    k = 0
    while True:
        robot.before_step()
        mujoco.mj_step(cell.model, cell.data)
        robot.after_step()
        for slot in watched:
            peak[slot] = max(peak[slot], _speed(cell, slot))
        k += 1
        if k % 20 == 0:
            for event in robot.suction.events:
                if event.kind == "released":
                    watch.note_released(event.item_id)
            throws += watch.update(cell.items, held_slots(robot.suction.held_slot))
        outcome = robot.poll()
        if outcome is not None:
            return outcome, peak, throws


def test_the_watch_judges_items_by_where_they_are_and_how_fast_they_move(cell):
    cell.reset(SPEED)
    outer = rail_outer_y(cell.model)
    assert outer == pytest.approx(0.43)
    on_belt = _spawn(cell, 0, "can_330_lying", -0.5, 0.0)
    beside = _spawn(cell, 1, "can_330_lying", -0.5, outer + 0.05)  # over the floor
    upstream = _spawn(cell, 2, "can_330_lying", -2.9, 0.0)  # upstream of the infeed
    flung = cell.pool.spawn(cell.data, 3, 0, -0.2, 0.1, 0.0, (1, 1, 1, 1), THROW_SPEED_MPS + 0.1)
    released = _spawn(cell, 4, "can_330_lying", 0.0, -0.56)  # let go of over the paper bin
    held = _spawn(cell, 5, "can_330_lying", 0.0, outer + 0.2)  # carried by the cup
    mujoco.mj_forward(cell.model, cell.data)
    watch = ThrowWatch(cell.model, cell.pool)
    watch.note_released(4)
    throws = {t.item_id: t.reason for t in watch.update(cell.items, held_slots(held))}
    assert throws == {1: "sideways", 2: "upstream", 3: "fast"}
    assert watch.update(cell.items, held_slots(held)) == []  # each item once
    assert {on_belt, beside, upstream, flung, released} == {0, 1, 2, 3, 4}


def test_the_cup_flies_over_a_standing_can_on_its_way_down(cell):
    cell.reset(SPEED)
    board = _spawn(cell, 0, "cardboard_flat", -0.30, -0.25)  # 4 mm flat, 0.25 x 0.18 m
    can = _spawn(cell, 1, "can_330_standing", -0.16, -0.12)  # 11.5 cm, on the way from home
    mujoco.mj_step(cell.model, cell.data, nstep=200)  # settle
    robot = PickController(cell, SPEED)
    x, y = (float(v) for v in cell.data.xpos[cell.pool.body_ids[board], :2])
    # Planned without the neighbours, the cup would come down onto the board through the can.
    top = robot.top_of(board)
    config = replace(robot.config, lift_height=robot.clear_z + PRESS_DEPTH_M)
    drop = np.array(robot.view.drop_xyz[PAPER])
    drop[2] = robot.clear_z + top
    blind = intercept_item(
        State.at_rest(robot.rest),
        (x, y),
        SPEED,
        drop,
        robot.view.generator,
        top - PRESS_DEPTH_M,
        config,
    )
    neighbours = [o for _, o in robot.neighbours(exclude=board)]
    t_down = blind.plan.chain.phase_start("descend")
    assert path_conflicts(blind.plan.chain, t_down, neighbours, SPEED, robot.suction.radius)
    hit = robot.plan(x, y, PAPER)
    assert hit.feasible, hit.reason
    assert robot.raises >= 1
    chain = hit.plan.chain
    assert not path_conflicts(chain, hit.plan.contact_time, neighbours, SPEED, 0.03)
    start = cell.data.xpos[cell.pool.body_ids[can]].copy()
    t0 = cell.data.time
    outcome, peak, throws = _play(robot, hit, [can])
    assert outcome.sealed and outcome.held_to_bin and outcome.item_id == 0
    assert throws == []
    assert peak[can] < 0.25  # carried by the belt (0.185 m/s), never struck
    now = cell.data.xpos[cell.pool.body_ids[can]]
    expected = start + np.array([SPEED * (cell.data.time - t0), 0.0, 0.0])
    assert np.linalg.norm(now - expected) < 0.005
    assert cell.data.xmat[cell.pool.body_ids[can]][8] > math.cos(0.05)  # still standing


def test_a_board_with_a_can_on_its_edge_is_not_picked(cell):
    cell.reset(SPEED)
    board = _spawn(cell, 0, "cardboard_flat", -0.30, -0.25)
    _spawn(cell, 1, "can_330_standing", -0.18, -0.15)  # overlaps the board's corner
    mujoco.mj_step(cell.model, cell.data, nstep=200)
    robot = PickController(cell, SPEED)
    x, y = (float(v) for v in cell.data.xpos[cell.pool.body_ids[board], :2])
    hit = robot.plan(x, y, PAPER)
    assert not hit.feasible
    assert "lies on it" in hit.reason


@pytest.mark.parametrize("gap_mm, refused", [(1.0, True), (4.0, True), (12.0, False)])
def test_a_board_a_lying_bottle_touches_edge_to_edge_waits(cell, gap_mm, refused):
    """A lying bottle whose outline comes within `TOUCH_GAP_M` of a flat board's edge: the
    board's lift would catch the bottle's flank (its outline 0.03 mm from a board's corner, a
    line of four robots flung it into the held board's way), so the board waits; the bottle,
    higher, may be picked. Farther away the board is picked."""
    cell.reset(SPEED)
    board = _spawn(cell, 0, "cardboard_flat", -0.30, -0.20)  # half 0.125 x 0.09 m
    radius = 0.045  # hdpe_bottle_1l: capsule radius [m], lying along the belt
    bottle = _spawn(cell, 1, "hdpe_bottle_1l", -0.30, -0.20 + 0.09 + radius + gap_mm * 1e-3)
    mujoco.mj_step(cell.model, cell.data, nstep=150)  # settle
    robot = PickController(cell, SPEED)
    gap = footprint_distances(
        [robot.obstacle_of(bottle)], outline_points(robot.obstacle_of(board)), np.zeros(81)
    ).min()
    assert gap > 0.0  # the outlines do not overlap: the lies-on check alone let it through
    x, y = (float(v) for v in cell.data.xpos[cell.pool.body_ids[board], :2])
    hit = robot.plan(x, y, PAPER)
    if refused:
        assert gap <= TOUCH_GAP_M
        assert not hit.feasible and "against its edge" in hit.reason
        bx, by = (float(v) for v in cell.data.xpos[cell.pool.body_ids[bottle], :2])
        assert robot.plan(bx, by, PLASTIC).feasible
    else:
        assert gap > TOUCH_GAP_M
        assert hit.feasible, hit.reason


def test_the_top_scrap_of_a_pile_is_picked_and_the_board_under_it_left(cell):
    """A paper scrap lying on a board: the board is refused (the scrap lies on it), the scrap
    is picked though the lip pressing it touches the board's top, and the board rides on."""
    cell.reset(SPEED)
    board = _spawn(cell, 0, "cardboard_flat", -0.30, -0.20)
    top = 2 * [t for t in cell.catalogue.types if t.name == "cardboard_flat"][0].size[2]
    k = [t.name for t in cell.catalogue.types].index("paper_scrap")  # 2 mm thick
    sheet = cell.pool.spawn(cell.data, 1, k, -0.25, -0.17, 0.0, (1, 1, 1, 1), SPEED, z_drop=top)
    mujoco.mj_step(cell.model, cell.data, nstep=200)
    robot = PickController(cell, SPEED)
    assert robot.lying_under(sheet, robot.neighbours(exclude=sheet)) == [board]
    x, y = (float(v) for v in cell.data.xpos[cell.pool.body_ids[board], :2])
    refused = robot.plan(x, y, PAPER)
    assert not refused.feasible and "lies on it" in refused.reason
    x, y = (float(v) for v in cell.data.xpos[cell.pool.body_ids[sheet], :2])
    hit = robot.plan(x, y, PAPER)
    assert hit.feasible, hit.reason
    outcome, peak, throws = _play(robot, hit, [board])
    assert outcome.sealed and outcome.held_to_bin and outcome.item_id == 1
    assert throws == [] and peak[board] < 0.5, peak
    mujoco.mj_step(cell.model, cell.data, nstep=300)
    assert abs(_speed(cell, board) - SPEED) < 0.02


def test_a_sheet_tilted_on_another_item_is_picked_at_its_surface(cell):
    """A folded sheet lying half on a crushed bottle, tilted by about 15 degrees: its highest
    corner is 5.5 mm above where the lip meets it. The cup comes down to that surface
    (aimed at the corner, it stopped short of the sheet and never sealed), seals and bins it,
    and the bottle under it rides on."""
    cell.reset(SPEED)
    types = {t.name: t for t in cell.catalogue.types}
    under = _spawn(cell, 0, "pet_bottle_0l5_crushed", -0.30, -0.20)
    k = [t.name for t in cell.catalogue.types].index("paper_folded_a6")
    top_under = 2 * types["pet_bottle_0l5_crushed"].size[2]
    sheet = cell.pool.spawn(
        cell.data, 1, k, -0.30, -0.12, 0.0, (1, 1, 1, 1), SPEED, z_drop=top_under
    )
    mujoco.mj_step(cell.model, cell.data, nstep=300)
    body = cell.pool.body_ids[sheet]
    assert math.degrees(math.acos(cell.data.xmat[body][8])) > 10.0  # tilted
    robot = PickController(cell, SPEED)
    x, y = (float(v) for v in cell.data.xpos[body, :2])
    top = robot.top_of(sheet)
    assert robot.lip_meets(sheet, x, y, top) < top - 0.004
    hit = robot.plan(x, y, PAPER)
    assert hit.feasible, hit.reason
    outcome, peak, throws = _play(robot, hit, [under])
    assert outcome.sealed and outcome.held_to_bin and outcome.item_id == 1
    assert throws == [] and peak[under] < 0.5, peak


def test_of_two_bottles_side_by_side_the_higher_is_picked_first(cell):
    """Two lying bottles touching side by side, both narrower than the lip, 2.6 mm apart in
    height: the lip coming down on either reaches over the other. The lower one waits (the
    higher lies against its edge, and the lip would rest on it); the higher one is picked, the
    lip pressing the lower one less deep than its own item, then the lower one. (Refusing both
    left them on the belt, each waiting for the other.)"""
    cell.reset(SPEED)
    k = [t.name for t in cell.catalogue.types].index("pet_bottle_0l5")
    radius = [t for t in cell.catalogue.types if t.name == "pet_bottle_0l5"][0].size[0]
    high, low = 0.92, 0.88
    y_low = 0.10 - radius * (high + low)  # touching
    higher = cell.pool.spawn(
        cell.data, 0, k, -0.30, 0.10, 0.0, (1, 1, 1, 1), SPEED, scale=(high,) * 3
    )
    lower = cell.pool.spawn(
        cell.data, 1, k, -0.30, y_low, 0.0, (1, 1, 1, 1), SPEED, scale=(low,) * 3
    )
    mujoco.mj_step(cell.model, cell.data, nstep=300)
    robot = PickController(cell, SPEED)
    assert robot.top_of(higher) - robot.top_of(lower) == pytest.approx(0.0026, abs=5e-4)

    def xy(slot):
        return tuple(float(v) for v in cell.data.xpos[cell.pool.body_ids[slot], :2])

    waits = robot.plan(*xy(lower), PLASTIC)
    assert not waits.feasible and "against its edge" in waits.reason
    hit = robot.plan(*xy(higher), PLASTIC)
    assert hit.feasible, hit.reason
    outcome, peak, throws = _play(robot, hit, [lower])
    assert outcome.sealed and outcome.held_to_bin and outcome.item_id == 0
    assert throws == [] and abs(peak[lower] - SPEED) < 0.05, peak
    assert robot.plan(*xy(lower), PLASTIC).feasible


def test_a_failed_seal_leaves_the_item_and_its_neighbour_on_the_belt(cell):
    cell.reset(SPEED)
    target = _spawn(cell, 0, "can_330_standing", -0.30, 0.10)
    types = {t.name: t for t in cell.catalogue.types}
    r = types["can_330_standing"].size[0]
    beside = _spawn(cell, 1, "can_330_standing", -0.30, 0.10 + 2 * r + 0.005)
    lying = _spawn(cell, 2, "pet_bottle_1l5", -0.30, 0.10 - r - 0.045 - 0.005)
    mujoco.mj_step(cell.model, cell.data, nstep=200)
    robot = PickController(cell, SPEED)
    # A seal that never forms (a leaking cup): the cup touches down, lifts and goes empty.
    robot.suction = SuctionCup(cell.model, cell.pool, SuctionConfig(seal_time=1.0))
    x, y = (float(v) for v in cell.data.xpos[cell.pool.body_ids[target], :2])
    hit = robot.plan(x, y, PLASTIC)
    assert hit.feasible, hit.reason
    outcome, peak, throws = _play(robot, hit, [target, beside, lying])
    assert not outcome.sealed and outcome.item_id == -1
    assert throws == []
    assert max(peak.values()) < 0.5, peak
    mujoco.mj_step(cell.model, cell.data, nstep=300)
    for slot in (target, beside, lying):
        pos = cell.data.xpos[cell.pool.body_ids[slot]]
        assert abs(pos[1]) < 0.4 and abs(_speed(cell, slot) - SPEED) < 0.02, (slot, pos)
    for slot in (target, beside):
        assert cell.data.xmat[cell.pool.body_ids[slot]][8] > math.cos(0.1)  # still standing


def test_a_held_bottle_rises_straight_up_from_beside_its_neighbour(cell):
    fast = 0.2775  # x1.5: a cup stopping along x while it lifts leaves the belt 1.3 cm behind
    cell.reset(fast)
    types = {t.name: t for t in cell.catalogue.types}
    bottle = _spawn(cell, 0, "pet_bottle_1l5", -0.30, 0.05, fast)
    end = types["pet_bottle_1l5"].half_length + types["can_330_lying"].half_length
    can = _spawn(cell, 1, "can_330_lying", -0.30 - end - 0.005, 0.05, fast)  # 5 mm upstream
    mujoco.mj_step(cell.model, cell.data, nstep=200)
    robot = PickController(cell, fast)
    x, y = (float(v) for v in cell.data.xpos[cell.pool.body_ids[bottle], :2])
    hit = robot.plan(x, y, PLASTIC)
    assert hit.feasible, hit.reason
    outcome, peak, throws = _play(robot, hit, [can])
    assert outcome.held_to_bin and outcome.item_id == 0
    assert throws == []
    # Untouched: the belt's speed. Stopping x during the lift, the bottle's end hit it (0.38 m/s).
    assert peak[can] < fast + 0.01, peak


def test_an_item_touching_another_robots_target_waits(cell):
    """Two items side by side, edge to edge: while another robot's pick aims at one
    (`aimed_by_others`, a line's controllers see each other's), the other is not picked (the
    first lift would drag it from under the cup); once that pick is over it is."""
    cell.reset(SPEED)
    board = _spawn(cell, 0, "cardboard_flat", -0.30, -0.20)  # half 0.125 x 0.09 m
    beside = _spawn(cell, 1, "cardboard_flat", -0.30, -0.20 + 2 * 0.09 + 0.002)
    far = _spawn(cell, 2, "cardboard_flat", -0.30, 0.15)
    mujoco.mj_step(cell.model, cell.data, nstep=150)  # settle
    robot = PickController(cell, SPEED)
    x, y = (float(v) for v in cell.data.xpos[cell.pool.body_ids[board], :2])
    robot.aimed_by_others = lambda: [beside]
    hit = robot.plan(x, y, PAPER)
    assert not hit.feasible and "another robot" in hit.reason
    robot.aimed_by_others = lambda: [far]
    assert robot.plan(x, y, PAPER).feasible


def test_a_lines_controllers_see_what_the_others_aim_at():
    from sim import config as episode_config
    from sim.episode import builder
    from sim.episode.runner import config_cell

    config = episode_config.from_dict({"perception": "truth", "robots": 2, "items": 5})
    line = config_cell(config)
    line.reset(SPEED)
    slot = _spawn(line, 0, "cardboard_flat", -0.30, -0.10)
    mujoco.mj_step(line.model, line.data, nstep=150)
    controllers = builder.pick_controllers(config, line, builder.episode_flow(config, line))
    first, second = controllers
    assert list(first.aimed_by_others()) == [] == list(second.aimed_by_others())
    x, y = (float(v) for v in line.data.xpos[line.pool.body_ids[slot], :2])
    hit = first.plan(x, y, PAPER)
    assert hit.feasible, hit.reason
    first.start(hit, 0)
    assert first.aimed_slot == slot and list(second.aimed_by_others()) == [slot]
    assert list(first.aimed_by_others()) == []


@pytest.mark.parametrize("gap_mm, refused", [(0.5, True), (4.0, True), (12.0, False)])
def test_a_sheet_a_higher_item_touches_edge_to_edge_waits(cell, gap_mm, refused):
    """An A4 sheet (2 mm) with a foil tray's rim within `TOUCH_GAP_M` of its edge: the rim may
    rest on the sheet's edge (a line's soak: lifting the sheet flipped the tray off the belt),
    so the sheet waits and the tray, higher, is picked; farther away the sheet is picked."""
    cell.reset(SPEED)
    sheet = _spawn(cell, 0, "paper_sheet_a4", -0.30, -0.20)  # half 0.1485 x 0.105 m
    tray = _spawn(cell, 1, "foil_tray", -0.30, -0.20 + 0.105 + 0.075 + gap_mm * 1e-3)
    mujoco.mj_step(cell.model, cell.data, nstep=150)  # settle
    robot = PickController(cell, SPEED)
    assert robot.top_of(sheet) - robot.belt_top_z <= SHEET_TOP_M < robot.top_of(tray)
    x, y = (float(v) for v in cell.data.xpos[cell.pool.body_ids[sheet], :2])
    hit = robot.plan(x, y, PAPER)
    if refused:
        assert not hit.feasible and "against its edge" in hit.reason
        tx, ty = (float(v) for v in cell.data.xpos[cell.pool.body_ids[tray], :2])
        assert robot.plan(tx, ty, ALUMINIUM).feasible
    else:
        assert hit.feasible, hit.reason


def test_a_scrap_over_a_sheets_edge_is_pressed_lightly_and_the_sheet_rides_on(cell):
    """A paper scrap lying partly on an A4 sheet's edge: the cup aims `ON_SHEET_PRESS_M` under
    the scrap's surface (not `PRESS_DEPTH_M`), seals, bins it, and the sheet rides on."""
    cell.reset(SPEED)
    sheet = _spawn(cell, 0, "paper_sheet_a4", -0.30, -0.20)  # half 0.1485 x 0.105 m
    k = [t.name for t in cell.catalogue.types].index("paper_scrap")
    scrap = cell.pool.spawn(
        cell.data, 1, k, -0.30 - 0.16, -0.20, 0.0, (1, 1, 1, 1), SPEED, z_drop=0.002
    )
    mujoco.mj_step(cell.model, cell.data, nstep=200)
    robot = PickController(cell, SPEED)
    assert robot.lying_under(scrap, robot.neighbours(exclude=scrap)) == [sheet]
    x, y = (float(v) for v in cell.data.xpos[cell.pool.body_ids[scrap], :2])
    hit = robot.plan(x, y, PAPER)
    assert hit.feasible, hit.reason
    meets = robot.lip_meets(scrap, x, y, robot.top_of(scrap))
    assert hit.pick_xyz[2] == pytest.approx(meets - ON_SHEET_PRESS_M, abs=2e-3)
    outcome, peak, throws = _play(robot, hit, [sheet])
    assert outcome.sealed and outcome.held_to_bin and outcome.item_id == 1
    assert throws == [] and peak[sheet] < 0.5, peak


@pytest.mark.parametrize("radius", [0.0, 1.35e-5, 0.004])
def test_outline_points_keep_a_boxs_corners_inside_its_footprint(radius):
    """The grid of a box's outline holds its (rounded) corners whatever its tilt's radius (a
    tilted cardboard's corner 3 mm over an A4 sheet went unseen when the corners were
    dropped), and every point lies in the footprint."""
    box = Obstacle(1.0, 0.2, 0.54, 0.117, 0.092, radius, 0.006)
    points = outline_points(box)
    assert points.shape == (81, 2)
    assert footprint_distances([box], points, np.zeros(81)).max() <= 1e-12
    c, s = np.cos(box.heading), np.sin(box.heading)
    reach = 0.117 + radius / np.sqrt(2.0)
    across = 0.092 + radius / np.sqrt(2.0)
    corner = (1.0 + c * reach - s * across, 0.2 + s * reach + c * across)
    assert np.min(np.hypot(*(points - corner).T)) < 1e-9
    sheet = Obstacle(
        1.0 + c * 0.117 - s * 0.092 + 0.2, 0.2 + s * 0.117 + c * 0.092, 0.0, 0.2029, 0.1, 0.0, 0.002
    )
    gap = footprint_distances([sheet], points, np.zeros(81)).min()
    assert gap == 0.0  # the box's corner pokes 2.9 mm into the sheet: seen
