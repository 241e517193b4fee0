"""The item pool: generated file up to date, spawn and park without recompiling, missed items."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.cell import item_pool
from sim.cell.conveyor import Belt
from sim.cell.item_pool import ItemPool
from sim.errors import InvalidInput
from sim.flow.catalogue import load_catalogue
from sim.flow.generator import POOL_CAPACITY_REQUIRED
from sim.model.item_pool_xml import ITEMS_XML, pool_xml
from sim.paths import REPO_ROOT

CATALOGUE = load_catalogue()
BELT_SCENE = REPO_ROOT / "tests" / "models" / "belt_items.xml"


def belt_scene():
    model = mujoco.MjModel.from_xml_path(str(BELT_SCENE))
    data = mujoco.MjData(model)
    belt = Belt(model)
    return model, data, belt, ItemPool(model, CATALOGUE, belt)


def test_committed_items_xml_is_up_to_date():
    assert ITEMS_XML.read_text() == pool_xml(CATALOGUE), "run: python -m sim.model.item_pool_xml"


def test_pool_holds_the_flow_capacity_parked_asleep_and_still():
    model, data, _, pool = belt_scene()
    assert pool.size == POOL_CAPACITY_REQUIRED
    for _ in range(200):
        mujoco.mj_step(model, data)
    assert data.ncon == 0
    assert data.ntree_awake == 0  # every parked slot sleeps
    np.testing.assert_array_equal(data.qpos, model.qpos0)


def test_spawn_sets_type_mass_colour_and_rest_pose_then_park_restores():
    model, data, _, pool = belt_scene()
    k = CATALOGUE.index("can_330_lying")
    rgba = CATALOGUE.colour_rgba("red")
    slot = pool.spawn(data, item_id=7, type_index=k, x=-2.5, y=0.1, yaw=0.3, rgba=rgba)
    body, geom = pool.body_ids[slot], pool.geom_id(slot)
    assert pool.slot_of(7) == slot and pool.item_type(slot).name == "can_330_lying"
    assert model.body_mass[body] == pytest.approx(0.0135)
    assert model.geom_rgba[geom].tolist() == pytest.approx(list(rgba))
    others = pool.geom_ids[slot][pool.geom_ids[slot] != geom]
    assert len(others) == 3 and geom in pool.geom_ids[slot]
    assert not model.geom_contype[others].any() and not model.geom_rgba[others, 3].any()
    assert model.geom_rgba[pool.label_ids[slot], 3] == 0.0  # no label asked for
    for _ in range(500):
        mujoco.mj_step(model, data)
    pos = pool.position(data, slot)
    assert pos[2] == pytest.approx(0.033, abs=5e-4)  # resting on the belt, axis horizontal
    assert pos[0] > -2.5 + 0.5 * 0.185 * 0.5  # carried downstream
    assert pool.park(data, slot) == 7
    assert pool.slot_of(7) is None and not model.geom_contype[pool.geom_ids[slot]].any()
    for _ in range(50):
        mujoco.mj_step(model, data)
    adr = pool.qpos_adr[slot]
    np.testing.assert_allclose(data.qpos[adr : adr + 7], model.qpos0[adr : adr + 7], atol=1e-12)
    assert data.ntree_awake == 0


def test_a_reused_slot_plays_a_different_type_with_its_own_mass():
    model, data, _, pool = belt_scene()
    light, heavy = CATALOGUE.index("paper_scrap"), CATALOGUE.index("hdpe_bottle_1l")
    slot = pool.spawn(data, 0, light, -2.5, 0.0, 0.0, CATALOGUE.rgba[0])
    pool.park(data, slot)
    assert pool.spawn(data, 1, heavy, -2.5, 0.0, 0.0, CATALOGUE.rgba[1]) == slot
    assert model.body_mass[pool.body_ids[slot]] == pytest.approx(0.040)
    mujoco.mj_forward(model, data)
    assert data.ncon == 0  # dropped above the belt, not into it


def test_refusals():
    _, data, _, pool = belt_scene()
    pool.spawn(data, 0, 0, -2.5, 0.0, 0.0, CATALOGUE.rgba[0])
    with pytest.raises(InvalidInput, match="item_id"):
        pool.spawn(data, 0, 0, -2.0, 0.0, 0.0, CATALOGUE.rgba[0])
    with pytest.raises(InvalidInput, match="type_index"):
        pool.spawn(data, 1, len(CATALOGUE.types), -2.0, 0.0, 0.0, CATALOGUE.rgba[0])
    for i in range(1, pool.size):
        pool.spawn(data, i, 0, -2.9 + 0.06 * i, 0.0, 0.0, CATALOGUE.rgba[0])
    with pytest.raises(InvalidInput, match=f"at most {pool.size}"):
        pool.spawn(data, pool.size, 0, 0.0, 0.0, 0.0, CATALOGUE.rgba[0])


def test_items_reaching_the_discharge_end_are_parked_as_missed():
    model, data, belt, pool = belt_scene()
    belt.set_factor(1.5)
    k = CATALOGUE.index("carton_box_small")
    pool.spawn(data, 3, k, 1.3, 0.0, 0.0, CATALOGUE.rgba[2])
    pool.spawn(data, 4, k, 0.5, 0.0, 0.0, CATALOGUE.rgba[2])
    missed = []
    while data.time < 1.0:
        mujoco.mj_step(model, data)
        missed += pool.park_missed(data)
    assert missed == [3]  # 0.2 m from the end at 0.2775 m/s: gone after ~0.72 s
    assert pool.slot_of(4) is not None


def test_feed_drops_a_generated_flow_in_order_with_its_types_colours_and_poses():
    from sim.flow.config import X_INFEED, FlowConfig
    from sim.flow.generator import generate_flow

    model, data, belt, pool = belt_scene()
    flow = generate_flow(FlowConfig(n_items=20, duration_s=10.0, seed=3), CATALOGUE)
    belt.set_speed(flow.config.belt_speed_mps)
    fed = 0
    while data.time < 5.0:
        fed = pool.feed(data, flow, fed)
        mujoco.mj_step(model, data)
    due = int(np.sum(flow.t_spawn <= 5.0 - model.opt.timestep / 2))
    assert fed == due and sorted(pool.item_ids[pool.active_slots()]) == list(range(due))
    assert not any(w.number for w in data.warning)
    for i in range(due):
        slot = pool.slot_of(i)
        assert pool.type_index[slot] == flow.variant[i]
        assert pool.item_type(slot) == flow.item_type(i, CATALOGUE)
        rgba = model.geom_rgba[pool.geom_id(slot)]
        assert rgba.tolist() == pytest.approx(flow.rgba[i].tolist())
        label = model.geom_rgba[pool.label_ids[slot]]
        assert label[3] == flow.label_rgba[i, 3]
        if label[3] > 0:
            assert label.tolist() == pytest.approx(flow.label_rgba[i].tolist())
        pos = pool.position(data, slot)
        expected_x = X_INFEED + flow.config.belt_speed_mps * (data.time - flow.t_spawn[i])
        assert pos[0] == pytest.approx(expected_x, abs=0.002)  # riding with the belt since its drop
        assert pos[1] == pytest.approx(flow.y[i], abs=0.002)


def test_a_dense_flow_rides_the_whole_belt_and_every_item_is_missed_in_order():
    """At x1.5 every item of a dense flow reaches the discharge end: none falls off the sides."""
    from sim.flow.config import FlowConfig
    from sim.flow.generator import generate_flow

    model, data, belt, pool = belt_scene()
    flow = generate_flow(
        FlowConfig(n_items=39, duration_s=12.0, speed_factor=1.5, seed=1), CATALOGUE
    )
    belt.set_speed(flow.config.belt_speed_mps)
    fed, missed, lowest = 0, [], np.inf
    while data.time < flow.t_spawn[-1] + 16.0:  # 4.25 m at 0.2775 m/s: 15.3 s
        fed = pool.feed(data, flow, fed)
        mujoco.mj_step(model, data)
        missed += pool.park_missed(data)
        active = pool.active_slots()
        if len(active):
            lowest = min(lowest, data.xpos[pool.body_ids[active], 2].min())
    assert fed == len(flow) and len(pool.active_slots()) == 0
    assert sorted(missed) == list(range(len(flow)))
    assert lowest > -0.005  # no item ever dropped below the belt surface
    assert not any(w.number for w in data.warning)


def test_a_pool_sized_for_its_flow_gives_the_results_of_the_full_pool():
    from sim import config as episode_config
    from sim.cell.item_pool import pool_size_for
    from sim.episode.runner import config_cell, run_episode

    cfg = episode_config.load(None, perception="truth", seed=12, items=30, duration_s=20.0)
    sized = config_cell(cfg, sized=True)
    full = config_cell(cfg)
    assert sized.pool.size < full.pool.size == sized.pool_capacity == 72
    a, b = run_episode(cfg, cell=sized), run_episode(cfg, cell=full)
    wall = ("wall_s", "real_time_factor")
    assert {k: v for k, v in a.episode_row.items() if k not in wall} == {
        k: v for k, v in b.episode_row.items() if k not in wall
    }
    assert a.pick_rows == b.pick_rows
    assert pool_size_for(27, 72) == 48 and pool_size_for(70, 72) == 72
    assert pool_size_for(0, 160) == 16


def test_a_flows_items_compiled_together_get_what_each_gets_alone_bit_for_bit():
    rng = np.random.default_rng(5)
    n = item_pool.PROPS_BATCH + 37  # two models, the second part full
    indices = rng.integers(len(CATALOGUE.types), size=n)
    scales = rng.uniform(0.6, 1.4, size=(n, 3))
    _, _, _, pool = belt_scene()
    pool.prepare(indices, scales)
    assert not pool._props  # nothing compiled one at a time
    for k, scale in zip(indices, scales, strict=True):
        alone = item_pool._batch_props([CATALOGUE.types[int(k)].scaled(scale)])[0]  # alone
        held = pool.props(int(k), scale)
        assert held.keys() == alone.keys()
        for name, value in alone.items():
            np.testing.assert_array_equal(held[name], value, err_msg=name)
    assert not pool._props  # every lookup of the flow's items served from the prepared ones
    assert {CATALOGUE.types[int(k)].shape for k in indices} >= {"box", "cylinder", "capsule"}
