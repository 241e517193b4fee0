"""The varied world: size factors, shape variants, colours, labels, gaps, overlaps; the uniform
world's flows unchanged; the item pool and the physics with scaled items."""

from __future__ import annotations

import colorsys
import dataclasses
import hashlib

import numpy as np
import pytest

from sim.errors import InvalidInput
from sim.flow.config import BELT_HALF_WIDTH, FlowConfig, thesis_duration_s
from sim.flow.footprint_polygons import polygon, shift_intervals
from sim.flow.generator import generate_flow
from sim.flow.world import UNIFORM_GAP_M, WorldVariation

# sha256 (first 16 hex digits) of the per-item arrays of flows generated before the varied world
# existed (commit 76d4a02); the uniform world must give them back, byte for byte.
UNIFORM_DIGESTS = {
    (100, 90.0, 1.0, 0): "fdf2a2860a5ccc44",
    (100, 90.0, 1.5, 7): "012dfe098f011bf4",
    (400, thesis_duration_s(400), 1.2, 3): "0101258383c79c25",
    (30, 20.0, 1.0, 11): "ac12db9aa3231b2c",
}
BASE_FIELDS = ("t_spawn", "y", "yaw", "type_index", "class_id", "colour", "stripe")


def digest(flow, fields=BASE_FIELDS) -> str:
    h = hashlib.sha256()
    for name in fields:
        h.update(np.ascontiguousarray(getattr(flow, name)).tobytes())
    return h.hexdigest()[:16]


@pytest.fixture(scope="module")
def big_varied(catalogue):
    return generate_flow(FlowConfig(n_items=2000, duration_s=1200.0, seed=4), catalogue)


@pytest.mark.parametrize("key", sorted(UNIFORM_DIGESTS))
def test_uniform_world_gives_the_flows_of_before(catalogue, key):
    n, duration, speed, seed = key
    config = FlowConfig(n, duration, speed, seed=seed, world=WorldVariation.uniform())
    flow = generate_flow(config, catalogue)
    assert digest(flow) == UNIFORM_DIGESTS[key]
    assert np.array_equal(flow.variant, flow.type_index)
    assert np.all(flow.scale == 1.0) and np.all(flow.z_drop == 0.0)
    assert np.array_equal(flow.rgba, np.array(catalogue.rgba)[flow.colour])
    assert np.all(flow.label_rgba == 0.0)
    assert all(flow.item_type(i, catalogue) is catalogue.types[flow.type_index[i]] for i in (0, 5))


def test_varied_world_keeps_the_base_draws_of_the_uniform_one(catalogue):
    """Classes, base types, colours, stripes and lateral places are drawn as in the uniform
    world (the variation has its own random stream); only drop times move (sizes, gaps)."""
    config = FlowConfig(n_items=400, duration_s=thesis_duration_s(400), seed=3)
    varied = generate_flow(config, catalogue)
    uniform = generate_flow(
        FlowConfig(n_items=400, duration_s=thesis_duration_s(400), seed=3,
                   world=WorldVariation.uniform()), catalogue,
    )  # fmt: skip
    # Item order can change where drop times move; compare per stripe, in order.
    for stripe in range(5):
        a, b = varied.stripe == stripe, uniform.stripe == stripe
        assert np.array_equal(varied.class_id[a], uniform.class_id[b])
        assert np.array_equal(varied.type_index[a], uniform.type_index[b])
        assert np.array_equal(varied.colour[a], uniform.colour[b])
    assert np.array_equal(np.bincount(varied.type_index), np.bincount(uniform.type_index))


def test_same_seed_same_bytes(catalogue):
    fields = (*BASE_FIELDS, "variant", "scale", "rgba", "label_rgba", "z_drop")
    a = generate_flow(FlowConfig(n_items=150, seed=9), catalogue)
    b = generate_flow(FlowConfig(n_items=150, seed=9), catalogue)
    c = generate_flow(FlowConfig(n_items=150, seed=10), catalogue)
    assert digest(a, fields) == digest(b, fields) != digest(c, fields)


def test_size_factors_within_bounds_and_spread(big_varied, catalogue):
    world = big_varied.config.world
    scale = big_varied.scale[:500]
    assert np.all(scale >= 1 - world.size_jitter) and np.all(scale <= 1 + world.size_jitter)
    assert scale[:, 0].std() > 0.05 and scale[:, 1].std() > 0.05
    sheets = np.array([catalogue.types[v].is_sheet for v in big_varied.variant])
    assert np.all(big_varied.scale[sheets, 2] == 1.0)  # sheets keep their thickness
    assert big_varied.scale[~sheets, 2].std() > 0.05
    for i in range(200):
        nominal = catalogue.types[big_varied.variant[i]]
        scaled = big_varied.item_type(i, catalogue)
        fx, fy, fz = big_varied.scale[i]
        assert scaled.mass == pytest.approx(nominal.mass * fx * fy * fz, rel=1e-12)
        assert scaled.half_length == pytest.approx(nominal.half_length * fx, rel=1e-12) or (
            nominal.footprint[0] == "stadium"  # a stadium's ends scale with the width
        )


def test_scaling_keeps_shapes_physical(catalogue):
    can = catalogue.types[catalogue.index("can_330_lying")].scaled((1.1, 0.9, 1.2))
    assert can.size == pytest.approx((0.033 * 0.9, 0.0575 * 1.1))  # radius: width and height
    pot = catalogue.types[catalogue.index("yoghurt_pot")].scaled((1.1, 0.9, 1.2))
    assert pot.size == pytest.approx((0.035 * 1.1, 0.0225 * 1.2))  # a disc stays a disc
    assert pot.mass == pytest.approx(0.006 * 1.1 * 1.1 * 1.2)
    sheet = catalogue.types[catalogue.index("paper_sheet_a4")].scaled((1.1, 0.9, 1.2))
    assert sheet.size[2] == 0.001 and sheet.mass == pytest.approx(0.010 * 1.1 * 0.9)


def test_crushed_and_crumpled_shares(catalogue):
    world = WorldVariation()
    flow = generate_flow(FlowConfig(n_items=6000, duration_s=3600.0, seed=1), catalogue)
    crushable = catalogue.variants("crushed")[flow.type_index] >= 0
    crushed = np.array([catalogue.types[v].kind == "crushed" for v in flow.variant])
    assert crushable.sum() > 1000
    assert abs(crushed[crushable].mean() - world.crushed_share) < 0.05
    assert not crushed[~crushable].any()
    crumplable = catalogue.variants("crumpled")[flow.type_index] >= 0
    crumpled = np.array([catalogue.types[v].kind == "crumpled" for v in flow.variant])
    assert abs(crumpled[crumplable].mean() - world.crumpled_share) < 0.05
    a4 = flow.type_index == catalogue.index("paper_sheet_a4")
    folded = np.array([catalogue.types[v].kind == "folded" for v in flow.variant])
    assert abs(folded[a4].mean() - world.folded_share) < 0.06
    # A variant keeps its base's class.
    assert all(catalogue.types[v].material == catalogue.types[k].material
               for v, k in zip(flow.variant, flow.type_index, strict=True))  # fmt: skip


def test_colours_jittered_within_bounds_transparent_kept_labels_on_round_items(
    big_varied, catalogue
):
    world = big_varied.config.world
    for i in range(300):
        nominal = np.array(catalogue.rgba[big_varied.colour[i]])
        rgba = big_varied.rgba[i]
        assert rgba[3] == nominal[3]  # transparent stays transparent
        h0, s0, v0 = colorsys.rgb_to_hsv(*nominal[:3])
        h, s, v = colorsys.rgb_to_hsv(*rgba[:3])
        dh = min(abs(h - h0), 1 - abs(h - h0)) * 360
        assert dh <= world.hue_jitter_deg + 1e-6 or s0 < 0.05  # hue is loose when grey
        assert v == pytest.approx(v0, rel=world.colour_jitter + 1e-6)
    round_items = np.array([catalogue.types[v].shape != "box" for v in big_varied.variant])
    labelled = big_varied.label_rgba[:, 3] > 0
    assert not labelled[~round_items].any()
    assert abs(labelled[round_items].mean() - world.label_share) < 0.05
    own = np.array(catalogue.rgba)[big_varied.colour][labelled, :3]
    assert np.all(np.abs(big_varied.label_rgba[labelled, :3] - own).max(axis=1) > 0.05)


def test_varied_flow_on_the_belt_touching_and_overlapping_only_flat_items(catalogue):
    """Footprints stay on the belt; two items overlap only where the later one, a box or a sheet
    lying down, lies partly over a flat item dropped before it, by at most the overlap depth,
    and is dropped onto it; no round or standing item is dropped onto another."""
    world = WorldVariation(overlap_share=0.5)
    config = FlowConfig(n_items=600, duration_s=300.0, seed=2, world=world)
    flow = generate_flow(config, catalogue)
    v = flow.config.belt_speed_mps
    types = flow.item_types(catalogue)
    shapes = np.array(
        [polygon(t, -v * ts, y, yaw) for t, ts, y, yaw in
         zip(types, flow.t_spawn, flow.y, flow.yaw, strict=True)]
    )  # fmt: skip
    assert np.all(np.abs(shapes[..., 1]) <= BELT_HALF_WIDTH + 1e-9)
    overlaps = touching = 0
    for i in range(1, len(flow)):
        # Touching (gap 0, to rounding) is not overlapping: 1 um of depth is let through.
        lo, hi = shift_intervals(shapes[i], shapes[:i], clearance=-1e-6)
        hit = np.flatnonzero((lo < 0) & (hi > 0))
        for j in hit:  # j dropped first (not later than i), flat, on the belt; i lands on it
            assert types[j].is_flat and flow.z_drop[j] == 0.0 and flow.z_drop[i] > 0.0, (i, j)
            # i has flat sides and lies down: a round item over an edge rolls off it
            assert types[i].shape == "box" and types[i].pose != "standing", (i, types[i].name)
            deep = shift_intervals(shapes[i], shapes[j : j + 1], -world.overlap_depth_m - 1e-6)
            assert not (deep[0][0] < 0 < deep[1][0]), (i, j)
            overlaps += 1
        lo, hi = shift_intervals(shapes[i], shapes[:i], clearance=UNIFORM_GAP_M)
        touching += int(np.any((lo < 0) & (hi > 0)))
    assert overlaps > 10 and touching > overlaps  # some lie over, more lie close
    raised = [types[i] for i in np.flatnonzero(flow.z_drop > 0.0)]
    assert raised and all(t.shape == "box" and t.pose != "standing" for t in raised)


def test_bad_settings_are_refused_by_name():
    for field, value in [
        ("size_jitter", 0.4),
        ("crushed_share", -0.1),
        ("label_share", float("nan")),
        ("min_gap_m", 0.1),
        ("overlap_depth_m", True),
    ]:
        with pytest.raises(InvalidInput) as error:
            WorldVariation(**{field: value})
        assert error.value.field == field
    with pytest.raises(InvalidInput, match="folded_share"):
        WorldVariation(crumpled_share=0.6, folded_share=0.5)
    with pytest.raises(InvalidInput, match="world"):
        FlowConfig(world="varied")


def test_episode_config_world_keys():
    from sim import config
    from sim.experiments.sweep_config import LATER_KEYS, LATER_TABLE_KEYS, settings_applied

    assert config.WORLD_NUMBERS == tuple(f.name for f in dataclasses.fields(WorldVariation))
    assert config.load(None).world_variation == WorldVariation()
    assert config.load(None, world="uniform").world_variation == WorldVariation.uniform()
    uniform_no_gap = config.load(None, world="uniform", min_gap_m=0.0).world_variation
    assert uniform_no_gap.min_gap_m == 0.0 and uniform_no_gap.size_jitter == 0.0
    # Every later key is an episode-config key; at the value LATER_KEYS holds the episode runs
    # as before the key existed (the uniform world, no depth noise, the HMMs' classes, no hold
    # at the infeed), in the layout the sweep's identity reads (`settings_applied`).
    before = config.load(
        None, world="uniform", classifier="hmm", depth_noise=False, min_class_confidence=0.0
    ).replace(belt=config.Belt(infeed_hold=False))
    before = settings_applied(before)  # as the identity reads it: the cup applied
    # A key added to a table later is left out of it at the value of before it existed.
    for table, keys in LATER_TABLE_KEYS.items():
        for key, value in keys.items():
            assert before[table].pop(key) == value
    assert all(before[key] == value for key, value in LATER_KEYS.items())


def test_pool_spawns_scaled_items_with_their_mass_bounds_and_label(catalogue):
    import mujoco

    from sim.cell.conveyor import Belt
    from sim.cell.item_pool import ItemPool
    from sim.paths import REPO_ROOT

    model = mujoco.MjModel.from_xml_path(str(REPO_ROOT / "tests" / "models" / "belt_items.xml"))
    data = mujoco.MjData(model)
    pool = ItemPool(model, catalogue, Belt(model))
    k = catalogue.index("pet_bottle_1l5")
    scale, label = (1.12, 0.9, 0.9), (0.9, 0.1, 0.1, 1.0)
    slot = pool.spawn(data, 3, k, -2.5, 0.0, 0.4, (0.2, 0.8, 0.3, 0.45), 0.0, scale, label)
    item_type = pool.item_type(slot)
    assert item_type == catalogue.types[k].scaled(scale)
    geom, body = pool.geom_id(slot), pool.body_ids[slot]
    assert model.geom_size[geom, :2] == pytest.approx(item_type.size)
    assert model.geom_rbound[geom] == pytest.approx(item_type.size[0] + item_type.size[1])
    assert model.body_mass[body] == pytest.approx(item_type.mass)
    assert model.geom_rgba[pool.label_ids[slot]].tolist() == pytest.approx(list(label))
    assert model.geom_contype[pool.label_ids[slot]] == 0
    for _ in range(400):
        mujoco.mj_step(model, data)
    assert pool.position(data, slot)[2] - pool.belt.geometry.top_z == pytest.approx(
        item_type.rest_height, abs=1e-3
    )
    pool.park(data, slot)
    assert model.geom_rgba[pool.label_ids[slot], 3] == 0.0


def test_varied_episode_settles_every_item_at_its_scaled_rest_height(cell):
    """A varied 100-item episode in the cell (truth perception, every item picked): no MuJoCo
    warning; every item crosses the camera line at rest, on the belt at its scaled rest height
    (or on the flat item it partly lies over), with its scaled mass."""
    from sim import config
    from sim.episode.loop import Episode
    from sim.flow.config import X_CAMERA

    settings = config.load(
        None, perception="truth", items=100, seed=0, planner="greedy", overlap_share=0.3
    )
    samples = {}
    with Episode(settings, cell) as episode:
        episode.reset()
        pool, data, observe = cell.pool, episode.data, episode.perception.observe

        def watched(t):
            for slot in pool.active_slots():
                x, _, z = data.xpos[pool.body_ids[slot]]
                if X_CAMERA - 0.2 <= x < X_CAMERA:  # the last rows before the camera line
                    samples[int(pool.item_ids[slot])] = (
                        z - pool.belt.geometry.top_z,
                        episode.parts.riding.linear_velocity(data, [slot])[0, 0],
                        float(cell.model.body_mass[pool.body_ids[slot]]),
                    )
            return observe(t)

        episode.perception.observe = watched
        episode.run()
        row, flow, speed = episode.metrics.row(), episode.parts.flow, episode.speed
    assert row["mujoco_warnings"] == 0
    assert len(samples) == len(flow) and (flow.z_drop > 0).sum() >= 2
    for i, (height, vx, mass) in samples.items():
        item_type = flow.item_type(i, cell.catalogue)
        rest, under = item_type.rest_height, float(flow.z_drop[i])
        if under == 0.0:
            assert height == pytest.approx(rest, abs=0.002), i
        else:  # tilted from the belt onto the flat item beneath
            assert rest - 0.002 <= height <= under + rest + 0.002, i
        assert vx == pytest.approx(speed, abs=0.01), i
        assert mass == pytest.approx(item_type.mass, rel=1e-9), i
