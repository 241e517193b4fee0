"""The sorting line's model (`sim.model.line_model`): one to four IRB 360s over one belt.

Figures (printed with `pytest -s tests/test_line_model.py`): the cost of one 1 ms step of the
4-robot line at home with the items parked.
"""

from __future__ import annotations

import dataclasses
import time

import mujoco
import numpy as np
import pytest

from planner.motion.limits import limits_for_payload
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from planner.motion.trajectory import State
from sim.cell.conveyor import Belt
from sim.cell.executor import TrajectoryExecutor, lumped_dynamics
from sim.cell.item_pool import ItemPool
from sim.cell.robot import geometry_from_model, loop_closure_error, tcp_position
from sim.cell.suction import SuctionCup
from sim.errors import InvalidInput
from sim.flow.catalogue import load_catalogue
from sim.model.line_model import (
    CAGE_GEOMS,
    CAMERA_BOX_GEOMS,
    MARKER_GEOMS,
    LineLayout,
    compile_line,
    reset_robot_home,
    robot_ctrl_index,
    robot_qpos_index,
)
from sim.model.mjcf import load_robot
from sim.model.scene_edits import CellSettings, compile_scene
from sim.monitors.energy import EnergyMeter
from sim.paths import REPO_ROOT

FOUR = REPO_ROOT / "experiments" / "catalogues" / "pet_hdpe.toml"


def model_bytes(model: mujoco.MjModel) -> bytes:
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return buffer.tobytes()


def at_home(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    return data


def body_of(model: mujoco.MjModel, geom: int) -> str:
    return model.body(model.geom_bodyid[geom]).name


@pytest.fixture(scope="module")
def line2() -> mujoco.MjModel:
    return compile_line(LineLayout(2))


@pytest.fixture(scope="module")
def line4() -> mujoco.MjModel:
    return compile_line(LineLayout(4))


@pytest.fixture(scope="module")
def robot() -> mujoco.MjModel:
    return load_robot()


# --- the layout -----------------------------------------------------------------------------


def test_default_layouts():
    assert LineLayout() == LineLayout(1, (0.0,), ("",))
    four = LineLayout(4)
    assert four.positions_m == (0.0, 1.8, 3.6, 5.4)
    assert four.prefixes == ("r0_", "r1_", "r2_", "r3_")
    assert LineLayout().belt_length_m == pytest.approx(4.5)  # the scene's belt
    assert four.belt_length_m == pytest.approx(9.9)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"robots": 0}, "line.robots"),
        ({"robots": 5}, "line.robots"),
        ({"robots": True}, "line.robots"),
        ({"robots": 2.0}, "line.robots"),
        ({"robots": 2, "positions_m": (0.0, 1.0)}, "line.positions_m"),  # cages overlap
        ({"robots": 2, "positions_m": (1.8, 0.0)}, "line.positions_m"),  # not downstream
        ({"robots": 1, "positions_m": (-0.5,)}, "line.positions_m"),  # under the camera
        ({"robots": 1, "positions_m": (16.0,)}, "line.positions_m"),  # belt over 20 m
        ({"robots": 2, "positions_m": (0.0,)}, "line.positions_m"),
        ({"robots": 1, "positions_m": (float("nan"),)}, "line.positions_m"),
        ({"robots": 2, "prefixes": ("", "r1_")}, "line.prefixes"),  # "" for one robot only
        ({"robots": 2, "prefixes": ("a_", "a_")}, "line.prefixes"),
        ({"robots": 1, "prefixes": ("r 0",)}, "line.prefixes"),
        ({"robots": 1, "prefixes": ("r0_", "r1_")}, "line.prefixes"),
        ({"robots": 1, "prefixes": ("r0_",)}, "line.prefixes"),  # a lone robot has one naming
        ({"robots": 2, "cameras_per_robot": 1}, "line.cameras_per_robot"),
    ],
)
def test_bad_layouts_are_refused_naming_the_field(kwargs, field):
    with pytest.raises(InvalidInput) as refused:
        LineLayout(**kwargs)
    assert refused.value.field == field


# --- one robot: today's cell ------------------------------------------------------------------


def test_a_line_of_one_robot_is_todays_cell_to_the_byte():
    assert model_bytes(compile_line(LineLayout())) == model_bytes(compile_scene())


def test_a_line_of_one_robot_with_settings_and_a_catalogue_is_the_cell_with_them():
    settings = CellSettings(cup_diameter_m=0.08, belt_length_m=6.0)
    materials = load_catalogue(FOUR).materials
    line = compile_line(LineLayout(), settings, materials)
    assert model_bytes(line) == model_bytes(compile_scene(settings, materials=materials))


def test_one_robot_moved_down_the_belt_takes_its_cage_and_bins_along():
    line, cell = compile_line(LineLayout(1, (0.7,))), compile_scene()
    data = at_home(line)
    np.testing.assert_allclose(tcp_position(line, data), [0.7, 0.0, 0.15], atol=1e-9)
    assert loop_closure_error(line, data) < 1e-8
    cell_data = at_home(cell)
    for site in ("bin_paper_drop", "bin_plastic_drop", "bin_aluminium_drop"):
        np.testing.assert_allclose(data.site(site).xpos - cell_data.site(site).xpos, [0.7, 0, 0])
    np.testing.assert_allclose(line.geom("cage_mount_plate").pos, [0.7, 0.0, 1.09])
    assert line.geom("belt").size[0] == pytest.approx(0.5 * (0.7 + 4.5))


def test_a_lone_robots_belt_is_the_configured_one_whatever_its_pool():
    short = CellSettings(belt_length_m=4.0)  # the range's shortest: ends 1.0 m past the robot
    for pool_size in (None, 24):
        line = compile_line(LineLayout(), short, pool_size=pool_size)
        assert 2 * line.geom("belt").size[0] == pytest.approx(4.0, abs=1e-12)
    moved = compile_line(LineLayout(1, (0.5,)), short, pool_size=24)
    assert 2 * moved.geom("belt").size[0] == pytest.approx(0.5 + 4.5, abs=1e-12)


_NAMED = {  # kind: the model's count of it
    "body": "nbody", "joint": "njnt", "geom": "ngeom", "site": "nsite", "actuator": "nu",
    "equality": "neq", "key": "nkey",
}  # fmt: skip


def names_but_the_pool(model: mujoco.MjModel) -> dict[str, set[str]]:
    """The names of a model's elements of each kind of `_NAMED`, less the item pool's
    (`item_<n>...`, as many as the pool has slots) and the legs under a longer belt."""
    out = {}
    for kind, count in _NAMED.items():
        obj = getattr(mujoco.mjtObj, f"mjOBJ_{kind.upper()}")
        names = {mujoco.mj_id2name(model, obj, i) or "" for i in range(getattr(model, count))}
        out[kind] = {n for n in names if not n.startswith(("item_", "belt_leg_"))}
    return out


def test_a_lone_robot_has_one_naming_wherever_it_stands_and_whatever_its_pool():
    from sim.cell.cell import Cell
    from sim.episode.runner import shared_cell
    from sim.model.mjcf import robot_elements

    cells = {
        "x = 0": Cell(),
        "moved": shared_cell(positions_m=(1.1,)),
        "small pool": shared_cell(pool_size=24),
        "dense": shared_cell(line=True, pool_size=100),
    }
    sizes = {name: cell.pool.size for name, cell in cells.items()}
    assert sizes == {"x = 0": 72, "moved": 160, "small pool": 24, "dense": 100}
    expected = names_but_the_pool(cells["x = 0"].model)
    for kinds, name in robot_elements(""):  # every name the code looks a robot's element up by
        assert any(name in expected[k] for k in kinds), name
    for name, cell in cells.items():
        assert [robot.prefix for robot in cell.robots] == [""], name
        assert names_but_the_pool(cell.model) == expected, name
        model = cell.model
        grips = [model.equality(f"item_{k}_grip").id for k in range(sizes[name])]
        assert {model.body(model.eq_obj1id[g]).name for g in grips} == {"cup_link"}, name
    moved = cells["moved"]
    np.testing.assert_allclose(tcp_position(moved.model, moved.data), [1.1, 0.0, 0.15], atol=1e-9)


# --- several robots -------------------------------------------------------------------------


@pytest.mark.parametrize("fixture", ["line2", "line4"])
def test_a_line_compiles_with_every_robot_element_prefixed(fixture, request, robot):
    line = request.getfixturevalue(fixture)
    layout = LineLayout(4 if fixture == "line4" else 2)
    n = layout.robots
    assert line.opt.timestep == robot.opt.timestep == 0.001
    assert line.opt.integrator == robot.opt.integrator
    assert line.nu == n * robot.nu and line.nkey == n + 1
    names = {kind: [getattr(line, kind)(i).name for i in range(count)] for kind, count in
             (("body", line.nbody), ("joint", line.njnt), ("actuator", line.nu),
              ("equality", line.neq))}  # fmt: skip
    for kind, own in (("body", robot.nbody), ("joint", robot.njnt), ("actuator", robot.nu)):
        for i in range(1 if kind == "body" else 0, own):  # the robot file's world is no body
            name = getattr(robot, kind)(i).name
            assert name not in names[kind]
            assert all(p + name in names[kind] for p in layout.prefixes)
    loops = [f"loop_{i}{r}" for i in (1, 2, 3) for r in "ab"]
    pool = ItemPool(line, load_catalogue(), Belt(line))
    assert np.all(pool.grip_ids < 0)  # no weld of the single cell's cup
    for prefix, x in zip(layout.prefixes, layout.positions_m, strict=True):
        assert all(prefix + loop in names["equality"] for loop in loops)
        grips = pool.grip_ids_of(prefix)
        assert np.all(grips >= 0) and len(grips) == pool.size
        cup = line.body(f"{prefix}cup_link").id
        assert np.all(line.eq_obj1id[grips] == cup)
        assert np.array_equal(line.eq_obj2id[grips], pool.body_ids)
        assert not np.any(line.eq_active0[grips])
        assert line.geom(f"{prefix}cage_mount_plate").pos[0] == pytest.approx(x)
        assert line.site(f"{prefix}bin_paper_drop").id >= 0
    for name in CAGE_GEOMS:  # the scene's own cage is gone, each robot has its copy
        assert mujoco.mj_name2id(line, mujoco.mjtObj.mjOBJ_GEOM, name) < 0
    assert line.geom("belt").size[0] == pytest.approx(0.5 * layout.belt_length_m)
    assert line.cam("belt_camera").pos[0] == pytest.approx(-1.48)


def test_each_robots_geometry_is_the_single_robots_at_its_own_base(line4):
    single = geometry_from_model(compile_scene())
    for prefix, x in zip(LineLayout(4).prefixes, LineLayout(4).positions_m, strict=True):
        geometry = geometry_from_model(line4, prefix=prefix)
        assert geometry.base_xy == pytest.approx((x, 0.0), abs=1e-12)
        moved = dataclasses.replace(geometry, base_xy=(0.0, 0.0))
        for field in dataclasses.fields(single):  # equal but for rounding in x - x_base
            got, want = getattr(moved, field.name), getattr(single, field.name)
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12, err_msg=field.name)


def test_each_robot_has_the_single_robots_physics(line4, robot):
    """Joints, actuators, bodies and loop closures of every robot equal the robot file's (the
    attached default classes resolved alike)."""
    for prefix in LineLayout(4).prefixes:
        for j in range(robot.njnt):
            a, b = robot.joint(j), line4.joint(prefix + robot.joint(j).name)
            np.testing.assert_array_equal(a.range, b.range)
            for field in ("dof_damping", "dof_armature", "dof_frictionloss"):
                np.testing.assert_array_equal(
                    getattr(robot, field)[a.dofadr[0]], getattr(line4, field)[b.dofadr[0]]
                )
        for i in range(robot.nu):
            a, b = robot.actuator(i), line4.actuator(prefix + robot.actuator(i).name)
            for field in ("gainprm", "biasprm", "forcerange", "ctrlrange"):
                np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
        for i in range(1, robot.nbody):
            a, b = robot.body(i), line4.body(prefix + robot.body(i).name)
            np.testing.assert_array_equal(a.mass, b.mass)
            np.testing.assert_array_equal(a.inertia, b.inertia)
        for i in range(robot.neq):
            a, b = robot.equality(i), line4.equality(prefix + robot.equality(i).name)
            np.testing.assert_array_equal(a.solref, b.solref)
            np.testing.assert_array_equal(a.solimp, b.solimp)
        cup = line4.geom(f"{prefix}cup_collision")
        assert cup.contype[0] == 1 and cup.size[0] == pytest.approx(0.03)
        single = lumped_dynamics(robot, geometry_from_model(robot))
        assert lumped_dynamics(line4, geometry_from_model(line4, prefix=prefix), prefix=prefix) == (
            single
        )


def test_each_robot_has_a_bin_per_material_of_a_catalogue():
    materials = load_catalogue(FOUR).materials
    line = compile_line(LineLayout(2), materials=materials)
    data = at_home(line)
    cell = at_home(compile_scene(materials=materials))
    for name in materials.names:
        site = f"bin_{name}_drop"
        for prefix, x in (("r0_", 0.0), ("r1_", 1.8)):
            np.testing.assert_allclose(
                data.site(prefix + site).xpos, cell.site(site).xpos + [x, 0, 0], atol=1e-12
            )


def test_the_cup_diameter_applies_to_every_robot():
    line = compile_line(LineLayout(2), CellSettings(cup_diameter_m=0.08))
    for prefix in ("r0_", "r1_"):
        assert line.geom(f"{prefix}cup_collision").size[0] == pytest.approx(0.04)


def test_every_robot_holds_home_with_its_loops_closed_for_1_s(line4):
    layout = LineLayout(4)
    data = at_home(line4)
    start = {p: tcp_position(line4, data, prefix=p) for p in layout.prefixes}
    for p, x in zip(layout.prefixes, layout.positions_m, strict=True):
        np.testing.assert_allclose(start[p], [x, 0.0, 0.15], atol=1e-9)
    worst = {p: 0.0 for p in layout.prefixes}
    for _ in range(1000):
        mujoco.mj_step(line4, data)
        for p in layout.prefixes:
            worst[p] = max(worst[p], loop_closure_error(line4, data, prefix=p))
    for p in layout.prefixes:
        assert worst[p] < 1e-4, (p, worst[p])
        assert np.linalg.norm(tcp_position(line4, data, prefix=p) - start[p]) < 1e-3
    assert sum(w.number for w in data.warning) == 0


def test_no_contact_between_robots_or_with_anothers_bins_at_home(line4):
    """At home nothing touches at all; the cups (the robots' only colliding geoms) are farther
    from every other robot's bins than the robot reaches (working radius 0.565 m)."""
    data = at_home(line4)
    mujoco.mj_step(line4, data)
    assert data.ncon == 0
    layout = LineLayout(4)
    for p in layout.prefixes:
        cup = tcp_position(line4, data, prefix=p)
        for q in layout.prefixes:
            if q == p:
                continue
            assert np.linalg.norm(tcp_position(line4, data, prefix=q)[:2] - cup[:2]) > 1.13
            for g in range(line4.ngeom):
                if body_of(line4, g).startswith(f"{q}bin_"):
                    assert abs(data.geom_xpos[g][0] - cup[0]) > 0.565 + 0.2


def test_a_robots_key_resets_it_alone(line2):
    data = at_home(line2)
    data.qpos[robot_qpos_index(line2, "r0_")] += 0.01
    data.qpos[robot_qpos_index(line2, "r1_")] += 0.02
    before = data.qpos.copy()
    reset_robot_home(line2, data, "r1_")
    r0, r1 = robot_qpos_index(line2, "r0_"), robot_qpos_index(line2, "r1_")
    np.testing.assert_array_equal(data.qpos[r0], before[r0])
    np.testing.assert_array_equal(data.qpos[r1], line2.key("home").qpos[r1])
    assert loop_closure_error(line2, data, prefix="r1_") < 1e-8
    np.testing.assert_array_equal(
        data.ctrl[robot_ctrl_index(line2, "r1_")], line2.key("r1_home").ctrl[4:]
    )


def _drive_one_robot(line: mujoco.MjModel, layout: LineLayout, k: int) -> None:
    """Robot k plays a short move while the others hold home: it tracks within 1 mm, they stay
    within 1 um of where they are when nobody moves (each settles under gravity by 0.3 mm)."""
    data = at_home(line)
    prefix = layout.prefixes[k]
    geometry = geometry_from_model(line, prefix=prefix)
    generator = RuckigTrajectoryGenerator(
        limits_for_payload(1.0), geometry, lumped_dynamics(line, geometry, 1.0, prefix=prefix)
    )
    home = tcp_position(line, data, prefix=prefix)
    goal = home + np.array([0.2, -0.15, -0.1])
    segment = generator.plan(State.at_rest(home), State.at_rest(goal, axis4=0.5))
    executor = TrajectoryExecutor(line, data, geometry=geometry, prefix=prefix)
    meter = EnergyMeter(line, data, prefix=prefix)
    log = executor.execute(segment, hold=0.1, on_step=lambda _t: meter.add(line.opt.timestep))
    still = at_home(line)
    mujoco.mj_step(line, still, nstep=len(log.time) * executor.substeps)
    others = {p: tcp_position(line, still, prefix=p) for p in layout.prefixes if p != prefix}
    assert np.max(log.tracking_error) < 1e-3
    assert np.linalg.norm(tcp_position(line, data, prefix=prefix) - goal) < 1e-3
    assert data.joint(f"{prefix}axis4_joint").qpos[0] == pytest.approx(0.5, abs=1e-2)
    assert meter.mechanical_j > 0.0
    for p, tcp in others.items():
        assert np.linalg.norm(tcp_position(line, data, prefix=p) - tcp) < 1e-6, p
        assert loop_closure_error(line, data, prefix=p) < 1e-4
    assert loop_closure_error(line, data, prefix=prefix) < 1e-4
    mine = robot_ctrl_index(line, prefix)  # the commands went to this robot's servos only
    untouched = np.setdiff1d(np.arange(line.nu), mine)
    np.testing.assert_array_equal(data.ctrl[untouched], line.key("home").ctrl[untouched])


@pytest.mark.parametrize("fixture", ["line2", "line4"])
def test_each_robot_is_driven_by_its_own_executor_while_the_others_hold(fixture, request):
    line = request.getfixturevalue(fixture)
    layout = LineLayout(4 if fixture == "line4" else 2)
    for k in range(layout.robots):
        _drive_one_robot(line, layout, k)


def test_each_robots_cup_seals_through_its_own_welds(line2):
    pool = ItemPool(line2, load_catalogue(), Belt(line2))
    cups = [SuctionCup(line2, pool, prefix=p) for p in ("r0_", "r1_")]
    assert cups[0].body_id != cups[1].body_id and cups[0].site_id != cups[1].site_id
    assert not set(cups[0].grip_ids) & set(cups[1].grip_ids)
    for cup, p in zip(cups, ("r0_", "r1_"), strict=True):
        assert line2.body(cup.body_id).name == f"{p}cup_link"
        assert cup.radius == pytest.approx(0.03)


def test_robot_r1_seals_lifts_and_releases_an_item_through_its_own_weld():
    model = compile_line(LineLayout(2))  # its own: the pool writes the model's geom fields
    data = at_home(model)
    model.geom_surfacevel[model.geom("belt").id] = 0.0  # the belt stopped under the robot
    catalogue = load_catalogue()
    pool = ItemPool(model, catalogue, Belt(model))
    k = catalogue.index("carton_box_small")
    slot = pool.spawn(data, 0, k, 1.8, 0.0, 0.0, catalogue.colour_rgba("blue"))
    mujoco.mj_step(model, data, nstep=300)
    cups = {p: SuctionCup(model, pool, prefix=p) for p in ("r0_", "r1_")}
    geometry = geometry_from_model(model, prefix="r1_")
    generator = RuckigTrajectoryGenerator(limits_for_payload(1.0), geometry)
    executor = TrajectoryExecutor(model, data, geometry=geometry, prefix="r1_")
    home = tcp_position(model, data, prefix="r1_")
    item = pool.position(data, slot)
    touch = np.array([item[0], item[1], 2 * pool.item_type(slot).rest_height - 0.002])

    def update(_t: float) -> None:
        for cup in cups.values():
            cup.update(data)

    cups["r1_"].vacuum_on()
    executor.execute(generator.plan(State.at_rest(home), State.at_rest(touch)), 0.1, update)
    assert cups["r1_"].held_slot == slot and cups["r0_"].held_slot is None
    assert data.eq_active[pool.grip_ids_of("r1_")[slot]] == 1
    assert not np.any(data.eq_active[pool.grip_ids_of("r0_")])
    executor.execute(generator.plan(State.at_rest(touch), State.at_rest(home)), 0.05, update)
    assert pool.position(data, slot)[2] > 0.1  # lifted with r1's cup
    cups["r1_"].vacuum_off(float(data.time))
    mujoco.mj_step(model, data, nstep=100)
    update(0.0)
    assert [e.kind for e in cups["r1_"].events] == ["sealed", "released"]
    assert not np.any(data.eq_active[pool.grip_ids_of("r1_")])


def test_step_cost_of_the_4_robot_line_at_home(line4):
    data = at_home(line4)
    for _ in range(200):  # the parked items fall asleep
        mujoco.mj_step(line4, data)
    steps = 1000
    start = time.perf_counter()
    mujoco.mj_step(line4, data, nstep=steps)
    cost = (time.perf_counter() - start) / steps
    print(f"\n4-robot line at home, items parked: {cost * 1e6:.0f} us per 1 ms step")
    assert cost < 5e-3  # real time with room to spare, even on a loaded machine


# --- a camera per robot ---------------------------------------------------------------------


def _geom_ids(model: mujoco.MjModel, names) -> list[int]:
    return [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n) for n in names]


@pytest.fixture(scope="module")
def line4_cameras() -> mujoco.MjModel:
    return compile_line(LineLayout(4, cameras_per_robot=True))


def test_camera_lines_sit_between_the_robots_or_at_the_scenes_offset():
    assert LineLayout(4).camera_lines_m == (-1.48,)
    assert LineLayout(4, cameras_per_robot=True).camera_lines_m == pytest.approx(
        (-1.48, 0.9, 2.7, 4.5)
    )
    # Robots far apart: the scene's 1.48 m upstream of the robot; else half-way.
    spread = LineLayout(3, (0.0, 3.5, 5.5), cameras_per_robot=True)
    assert spread.camera_lines_m == pytest.approx((-1.48, 2.02, 4.5))
    assert spread.camera_prefixes == ("", "r1_", "r2_")
    assert LineLayout(cameras_per_robot=True).camera_lines_m == (-1.48,)


def test_a_line_with_a_camera_per_robot_names_every_camera_element(line4_cameras):
    line, layout = line4_cameras, LineLayout(4, cameras_per_robot=True)
    scene = compile_scene()
    box = scene.geom("camera_box_top")
    for prefix, x_line in zip(layout.camera_prefixes, layout.camera_lines_m, strict=True):
        camera = line.cam(f"{prefix}belt_camera")
        np.testing.assert_allclose(camera.pos, [x_line, 0.0, 0.75])
        np.testing.assert_allclose(camera.quat, scene.cam("belt_camera").quat)
        assert camera.fovy[0] == 60.0 and line.cam_resolution[camera.id].tolist() == [1280, 720]
        ids = _geom_ids(line, [prefix + n for n in (*CAMERA_BOX_GEOMS, *MARKER_GEOMS)])
        assert min(ids) >= 0, "every element of the camera's rig is named"
        for g in ids:  # drawn only, in the frame's group, never colliding
            assert line.geom_contype[g] == line.geom_conaffinity[g] == 0
            assert line.geom_group[g] == 2
        for i in range(4):  # the scene's colours, on the belt plane, around the camera line
            marker = line.geom(f"{prefix}marker_{i}")
            np.testing.assert_allclose(marker.rgba, scene.geom(f"marker_{i}").rgba)
            assert marker.pos[2] + marker.size[2] == pytest.approx(0.0)
            assert abs(marker.pos[0] - x_line) == pytest.approx(0.32 if prefix == "" else 0.2)
        if prefix:
            assert line.geom(f"{prefix}camera_box_top").matid == box.matid
    assert line.ncam == 5  # four belt cameras and the overview camera


def test_cameras_per_robot_add_only_the_cameras_rigs(line4_cameras, line4):
    assert line4_cameras.nbody == line4.nbody and line4_cameras.nq == line4.nq
    rig = 4 * (len(CAMERA_BOX_GEOMS) + len(MARKER_GEOMS))
    assert line4_cameras.ngeom == line4.ngeom + 3 * rig // 4
    assert mujoco.mj_name2id(line4, mujoco.mjtObj.mjOBJ_CAMERA, "r1_belt_camera") < 0
    off = compile_line(LineLayout(2, cameras_per_robot=False))
    assert model_bytes(off) == model_bytes(compile_line(LineLayout(2)))


def test_each_cameras_box_clears_both_robots_over_their_reach(line4_cameras):
    """Robots r0 and r1 at every reachable point of their windows up to 0.4 m above the belt:
    no part of either comes within 5 cm of camera r1's box (drawn only: MuJoCo would not
    report it) or between the camera and one of its markers."""
    from planner.motion.kinematics import inverse_kinematics, reachable_mask
    from sim.cell.robot import set_configuration
    from sim.cell.robots import RobotView

    line = line4_cameras
    data = at_home(line)
    box = _geom_ids(line, [f"r1_{n}" for n in CAMERA_BOX_GEOMS])
    markers = np.array([line.geom(f"r1_marker_{i}").pos for i in range(4)])
    eye = line.cam("r1_belt_camera").pos
    sight = eye + np.linspace(0.0, 1.0, 200)[:, None, None] * (markers - eye)
    fromto = np.zeros(6)
    for k, prefix in enumerate(("r0_", "r1_")):
        view = RobotView(line, data, k, prefix, load_catalogue().materials)
        geo, window = view.geometry, view.window
        parts = [g for g in range(line.ngeom) if body_of(line, g).startswith(prefix)
                 and "bin" not in body_of(line, g)]  # fmt: skip
        nearest = np.inf
        for y in np.linspace(-0.4, 0.4, 9):
            for x in np.linspace(*window.bounds(y), 6):
                for z in (0.02, 0.2, 0.4):
                    p = np.array([x, y, z])
                    if not reachable_mask(geo, p[None])[0]:
                        continue
                    set_configuration(
                        line, data, inverse_kinematics(geo, p), geom=geo, prefix=prefix
                    )
                    for g in parts:
                        for b in box:
                            nearest = min(
                                nearest, mujoco.mj_geomDistance(line, data, g, b, 0.2, fromto)
                            )
                        # The sight lines in the part's frame against its bounding box.
                        local = (sight - data.geom_xpos[g]) @ data.geom_xmat[g].reshape(3, 3)
                        centre, half = line.geom_aabb[g][:3], line.geom_aabb[g][3:]
                        assert not np.any(np.all(np.abs(local - centre) <= half, axis=-1))
        assert nearest > 0.05
