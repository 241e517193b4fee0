"""Every MJCF of the project compiles, steps cleanly and names what the code touches.

As MuJoCo Menagerie's model test: deterministic pseudorandom controls across each ctrlrange for
1 s of simulated time, and any MuJoCo warning fails.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.cli import main as cli
from sim.errors import InvalidInput, ModelFileError
from sim.model.mjcf import load_model
from sim.paths import MODELS_DIR, ROBOT_XML, SCENE_XML

MODEL_FILES = sorted({ROBOT_XML, *MODELS_DIR.glob("**/scene*.xml")})
ROBOT_ROOTS = ("base_link", "platform_link")


@pytest.mark.parametrize("path", MODEL_FILES, ids=lambda p: str(p.relative_to(MODELS_DIR)))
def test_compiles_and_steps_one_second_without_warnings(path):
    model = load_model(path)
    data = mujoco.MjData(model)
    if model.nkey and model.key("home") is not None:
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    rng = np.random.default_rng(0)
    lo, hi = model.actuator_ctrlrange.T
    steps = int(round(1.0 / model.opt.timestep))
    hold = max(1, int(round(0.05 / model.opt.timestep)))  # a new command every 50 ms
    for k in range(steps):
        if k % hold == 0:
            data.ctrl[:] = rng.uniform(lo, hi)
        mujoco.mj_step(model, data)
    counts = {mujoco.mjtWarning(i).name: w.number for i, w in enumerate(data.warning) if w.number}
    assert counts == {}
    assert np.all(np.isfinite(data.qpos))


def _in_robot(model: mujoco.MjModel, body: int) -> bool:
    roots = {model.body(name).id for name in ROBOT_ROOTS}
    while body != 0:
        if body in roots:
            return True
        body = model.body_parentid[body]
    return False


@pytest.mark.parametrize("path", MODEL_FILES, ids=lambda p: str(p.relative_to(MODELS_DIR)))
def test_every_element_the_code_touches_has_a_name(path):
    model = load_model(path)
    unnamed = []
    kinds = {
        "body": (model.nbody, model.body, range(1, model.nbody)),  # 0 is the world
        "joint": (model.njnt, model.joint, range(model.njnt)),
        "site": (model.nsite, model.site, range(model.nsite)),
        "actuator": (model.nu, model.actuator, range(model.nu)),
        "equality": (model.neq, model.equality, range(model.neq)),
        "camera": (model.ncam, model.camera, range(model.ncam)),
        "light": (model.nlight, model.light, range(model.nlight)),
    }
    for kind, (_, view, ids) in kinds.items():
        unnamed += [f"{kind} {i}" for i in ids if not view(i).name]
    robot_geoms = [g for g in range(model.ngeom) if _in_robot(model, model.geom_bodyid[g])]
    unnamed += [f"robot geom {g}" for g in robot_geoms if not model.geom(g).name]
    assert unnamed == []


def test_shared_names_exist():
    model = load_model(SCENE_XML)
    for body in ("base_link", "platform_link", "cup_link", "bin_paper", "bin_plastic"):
        model.body(body)
    for i in (1, 2, 3):
        model.body(f"upper_arm_{i}_link")
        model.joint(f"motor_{i}_joint")
        model.actuator(f"motor_{i}")
    model.joint("axis4_joint")
    model.actuator("axis4")
    for site in ("cup_site", "attachment_site"):
        model.site(site)
    for cls in ("paper", "plastic", "aluminium"):
        model.body(f"bin_{cls}")
        model.site(f"bin_{cls}_drop")
        model.site(f"bin_{cls}_floor")
    for geom in ("belt", "rail_left", "rail_right", *(f"marker_{i}" for i in range(4))):
        model.geom(geom)
    for cam in ("belt_camera", "overview_camera"):
        model.camera(cam)
    assert any(model.light(i).name.startswith("light_") for i in range(model.nlight))
    model.key("home")


def test_cell_layout_matches_design():
    model = load_model(SCENE_XML)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    belt = data.geom("belt")
    size = model.geom("belt").size
    assert belt.xpos[2] + size[2] == pytest.approx(0.0, abs=1e-12)  # top surface at z = 0
    assert belt.xpos[0] - size[0] == pytest.approx(-3.0)
    assert belt.xpos[0] + size[0] == pytest.approx(1.5)
    assert size[1] == pytest.approx(0.4)
    np.testing.assert_allclose(model.geom_surfacevel[model.geom("belt").id, :3], [0.185, 0.0, 0.0])
    np.testing.assert_allclose(data.cam("belt_camera").xpos, [-1.48, 0.0, 0.75])
    np.testing.assert_allclose(
        data.cam("belt_camera").xmat.reshape(3, 3)[:, 2], [0, 0, 1], atol=1e-12
    )
    assert data.site("bin_paper_drop").xpos[1] < -0.4
    assert data.site("bin_plastic_drop").xpos[1] > 0.4
    assert data.site("bin_aluminium_drop").xpos[1] > 0.4
    # The markers lie in the belt camera's view, beside the belt.
    fovy = np.deg2rad(model.camera("belt_camera").fovy[0])
    half_y = 0.75 * np.tan(fovy / 2)
    half_x = half_y * model.vis.global_.offwidth / model.vis.global_.offheight
    for i in range(4):
        x, y, _ = data.geom(f"marker_{i}").xpos
        assert abs(x + 1.48) < half_y and abs(y) < half_x and abs(y) > 0.4


def test_no_contacts_inside_the_robot():
    model = load_model(ROBOT_XML)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    for _ in range(20):
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        data.ctrl[:3] = rng.uniform(-0.5, 1.5, 3)
        for _ in range(200):
            mujoco.mj_step(model, data)
        assert data.ncon == 0


def test_missing_and_corrupt_files_are_refused(tmp_path):
    missing = tmp_path / "missing.xml"
    with pytest.raises(ModelFileError, match="missing.xml") as exc:
        load_model(missing)
    assert isinstance(exc.value, InvalidInput)
    corrupt = tmp_path / "corrupt.xml"
    corrupt.write_text("<mujoco><worldbody><body><geom type='sphere'/></worldbody></mujoco>")
    with pytest.raises(ModelFileError, match="corrupt.xml") as exc:
        load_model(corrupt)
    assert "\n" not in str(exc.value)


def test_cli_reports_a_bad_model_in_one_line_with_exit_2(tmp_path, monkeypatch, capsys):
    corrupt = tmp_path / "broken_scene.xml"
    corrupt.write_text("<mujoco><worldbody><geom type='box'/></mujoco>")

    class Command:
        @staticmethod
        def add_arguments(parser):
            pass

        @staticmethod
        def main(args):
            load_model(corrupt)

    monkeypatch.setattr(cli, "_module", lambda name: Command)
    assert cli.main(["cycle"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert "broken_scene.xml" in err
