"""The cell's settings in the episode config: camera resolution, cup diameter and vacuum, belt
length. Defaults leave the model as the scene file has it; other values change the compiled
model (the cup's lip, the belt's discharge end) and the physics and perception that follow."""

from __future__ import annotations

import math
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from perception.codes import EMPTY_CODE
from sim import config
from sim.cell.conveyor import Belt
from sim.cell.item_pool import ItemPool
from sim.cell.suction import SuctionConfig, SuctionCup
from sim.config.plant import BELT_LENGTH_M, CUP_DIAMETER_M, CellSettings
from sim.episode.loop import Episode
from sim.episode.runner import shared_cell
from sim.errors import InvalidInput
from sim.evaluation.perception_eval import evaluate_camera
from sim.flow.catalogue import load_catalogue
from sim.flow.world import WorldVariation
from sim.model.mjcf import CELL_ELEMENTS, compile_spec, load_scene, load_spec
from sim.model.scene_edits import apply_settings, compile_scene
from sim.paths import SCENE_XML

CATALOGUE = load_catalogue()
_FIELDS = ("geom_size", "geom_pos", "geom_rbound", "body_pos", "body_mass", "cam_pos", "site_pos")


@pytest.fixture(scope="module")
def scene() -> mujoco.MjModel:
    return load_scene()


def test_defaults_are_the_scene_files_numbers(scene):
    assert 2 * scene.geom("cup_collision").size[0] == pytest.approx(CUP_DIAMETER_M, abs=1e-12)
    assert 2 * scene.geom("belt").size[0] == pytest.approx(BELT_LENGTH_M, abs=1e-12)
    c = config.load(None)
    assert c.cell_settings == CellSettings() and c.cell_settings.is_default
    assert (c.camera.size, c.cup.vacuum_pa) == ((640, 360), SuctionConfig().vacuum)
    # The defaults compile the file as it is; the edits written at the defaults change nothing.
    default = compile_scene(CellSettings())
    spec = load_spec(SCENE_XML, CELL_ELEMENTS)
    apply_settings(spec, CellSettings())
    edited = compile_spec(spec, SCENE_XML, CELL_ELEMENTS)
    for model in (default, edited):
        assert (model.ngeom, model.nbody) == (scene.ngeom, scene.nbody)
        for name in _FIELDS:
            np.testing.assert_array_equal(getattr(model, name), getattr(scene, name), name)


def test_cup_diameter_changes_the_lip_and_the_holding_force(scene):
    model = compile_scene(CellSettings(cup_diameter_m=0.08))
    lip, bellows = model.geom("cup_collision"), model.geom("cup_bellows")
    assert lip.size[0] == pytest.approx(0.04, abs=1e-12)
    assert bellows.size[0] - lip.size[0] == pytest.approx(0.002, abs=1e-12)  # its overhang
    assert lip.rbound[0] > scene.geom("cup_collision").rbound[0]  # the collision bound follows
    np.testing.assert_array_equal(model.body_mass, scene.body_mass)  # inertia explicit
    pool = ItemPool(model, CATALOGUE, Belt(model))
    cup = SuctionCup(model, pool, SuctionConfig(vacuum=50e3))
    assert cup.radius == pytest.approx(0.04, abs=1e-12)
    assert cup.force_budget == pytest.approx(math.pi * 0.04**2 * 50e3, rel=1e-9)  # 251.3 N
    default = SuctionCup(scene, ItemPool(scene, CATALOGUE, Belt(scene)))
    assert default.force_budget == pytest.approx(math.pi * 0.03**2 * 80e3, rel=1e-9)  # 226.2 N


def _ride_to_the_end(model: mujoco.MjModel, x0: float, seconds: float):
    """One carton dropped at `x0` on the belt at x1.5: (where it is, ids parked as missed)."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    belt = Belt(model)
    belt.set_factor(1.5)
    pool = ItemPool(model, CATALOGUE, belt)
    k = CATALOGUE.index("carton_box_small")
    slot = pool.spawn(data, 0, k, x0, 0.0, 0.0, CATALOGUE.rgba[2])
    missed = []
    while data.time < seconds:
        mujoco.mj_step(model, data)
        missed += pool.park_missed(data)
    position = None if missed else pool.position(data, slot).copy()
    return belt.geometry, position, missed


def test_a_longer_belt_carries_an_item_farther_before_it_leaves(scene):
    longer = compile_scene(CellSettings(belt_length_m=6.0))
    for name in ("camera", "robot"):  # the camera and the robot stay where they are
        np.testing.assert_array_equal(longer.cam_pos, scene.cam_pos, name)
        np.testing.assert_array_equal(longer.body("base_link").pos, scene.body("base_link").pos)
    # The scene's belt: the carton, 0.2 m from the end at 0.2775 m/s, has left it by 1.5 s.
    geometry, position, missed = _ride_to_the_end(scene, 1.3, 1.5)
    assert (geometry.x_infeed, geometry.x_discharge) == pytest.approx((-3.0, 1.5))
    assert missed == [0] and position is None
    # 1.5 m longer: it rides on, on the belt, carried the belt's 0.42 m downstream.
    geometry, position, missed = _ride_to_the_end(longer, 1.3, 1.5)
    assert (geometry.x_infeed, geometry.x_discharge) == pytest.approx((-3.0, 3.0))
    assert missed == []
    assert position[0] == pytest.approx(1.3 + 0.2775 * 1.5, abs=0.02)
    rest = CATALOGUE.types[CATALOGUE.index("carton_box_small")].rest_height
    assert position[2] == pytest.approx(geometry.top_z + rest, abs=2e-3)
    # The frame, rails and legs follow the belt; a long belt gets more legs.
    for name in ("belt_frame", "rail_left", "rail_right"):
        g = longer.geom(name)
        assert g.pos[0] + g.size[0] == pytest.approx(3.0) and g.pos[0] - g.size[0] == pytest.approx(
            -3.0
        )
    assert longer.geom("belt_leg_discharge_left").pos[0] == pytest.approx(2.9)
    long20 = compile_scene(CellSettings(belt_length_m=20.0))
    legs = sorted(
        long20.geom(i).pos[0] for i in range(long20.ngeom) if "leg" in long20.geom(i).name
    )
    assert np.diff(legs[::2]).max() <= 2.4 + 1e-9


def test_episodes_get_a_cell_compiled_with_their_settings():
    settings = CellSettings(cup_diameter_m=0.08, belt_length_m=6.0)
    cell = shared_cell(settings)
    assert shared_cell(CellSettings(0.08, 6.0)) is cell and shared_cell() is not cell
    assert cell.cup_radius == pytest.approx(0.04) and cell.cup_extra_m == pytest.approx(0.01)
    assert cell.belt.geometry.x_discharge == pytest.approx(3.0)
    assert cell.wake_x == pytest.approx(shared_cell().wake_x - 0.01)  # the larger cup reaches
    # A short truth episode on it: the config's cup and vacuum are the episode's.
    c = config.from_dict(
        {"items": 8, "duration_s": 8.0, "perception": "truth", "planner": "proximity",
         "cup": {"diameter_m": 0.08, "vacuum_pa": 50e3}, "belt": {"length_m": 6.0}}
    )  # fmt: skip
    assert c.cell_settings == settings
    with Episode(c, cell) as episode:
        episode.reset()
        assert episode.robot.suction.force_budget == pytest.approx(math.pi * 0.04**2 * 50e3)
        episode.run()
    assert episode.metrics.row()["picked"] >= 6
    # A cell compiled otherwise is refused, naming the key.
    with pytest.raises(InvalidInput, match=r"^cup\.diameter_m"):
        Episode(c.replace(cup=config.Cup(diameter_m=0.05)), cell).reset()


@pytest.mark.parametrize("size", [(384, 216), (960, 540)])
def test_other_camera_resolutions_still_give_the_truths_codes(size):
    """The short uniform flow of `tests/test_observe.py` at the lowest resolution accepted and
    at 1.5 x the default: the calibration scaled to the frame, the codes as good."""
    config.Camera(*size)  # accepted by the config
    uniform = WorldVariation.uniform()
    score = evaluate_camera(1.0, n_items=30, duration_s=15.0, seed=3, size=size, world=uniform)
    busy = score.n_cells - score.confusion[EMPTY_CODE - 1, EMPTY_CODE - 1]
    assert score.unobserved == 0 and busy >= 40
    assert score.agreement >= 0.95, score.report()


@pytest.mark.parametrize(
    ("table", "key"),
    [
        ({"camera": {"width": 320, "height": 180}}, "camera.width"),
        ({"camera": {"width": 650}}, "camera.width"),
        ({"camera": {"width": 960}}, "camera.height"),  # 360 is not 960 x 9/16
        ({"camera": {"width": 640, "height": 480}}, "camera.height"),
        ({"camera": {"width": 640.0}}, "camera.width"),
        ({"camera": {"depth": 1}}, "camera.depth"),
        ({"cup": {"diameter_m": 0.5}}, "cup.diameter_m"),
        ({"cup": {"diameter_m": 0.0}}, "cup.diameter_m"),
        ({"cup": {"diameter_m": "wide"}}, "cup.diameter_m"),
        ({"cup": {"vacuum_pa": 2e5}}, "cup.vacuum_pa"),
        ({"cup": {"vacuum_pa": 0}}, "cup.vacuum_pa"),
        ({"cup": {"vacuum_pa": float("nan")}}, "cup.vacuum_pa"),
        ({"belt": {"length_m": 3.0}}, "belt.length_m"),
        ({"belt": {"length_m": 25.0}}, "belt.length_m"),
        ({"belt": {"length_m": True}}, "belt.length_m"),
        ({"belt": 4.5}, "belt"),
    ],
)
def test_bad_values_refused_naming_the_key(table, key):
    with pytest.raises(InvalidInput) as exc:
        config.from_dict(table, "c.toml")
    message = str(exc.value)
    assert message.startswith(key + " in c.toml: allowed") and "\n" not in message


def test_accepted_values_round_trip():
    table = {
        "camera": {"width": 1280, "height": 720},
        "cup": {"diameter_m": 0.02, "vacuum_pa": 1e3},
    }
    c = config.from_dict({**table, "belt": {"length_m": 20}})
    assert c.camera.size == (1280, 720) and c.cell_settings == CellSettings(0.02, 20.0)
    assert config.from_dict(c.to_dict()) == c
    with pytest.raises(InvalidInput, match="^belt.length_m"):
        CellSettings(belt_length_m=3.9)


def test_cli_refuses_a_bad_cell_setting_with_exit_2_in_one_line(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[belt]\nlength_m = 2.0\n")
    args = [sys.executable, "-m", "sim.cli.main", "run", "--config", str(path)]
    proc = subprocess.run(args + ["--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "belt.length_m" in lines[0] and str(path) in lines[0]
    assert not (tmp_path / "out").exists()
