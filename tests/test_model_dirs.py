"""Every model folder follows MuJoCo Menagerie's layout, and every scene in it steps cleanly.

A model folder holds README.md, LICENSE, CHANGELOG.md and at least one scene*.xml. Each scene
compiles and survives 500 steps of deterministic pseudorandom controls across each actuator's
ctrlrange (a new command every 50 steps) without a single MuJoCo warning.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

MODELS_DIR = Path(__file__).resolve().parents[1] / "models"
MODEL_DIRS = sorted(p for p in MODELS_DIR.iterdir() if p.is_dir())
SCENE_FILES = sorted(MODELS_DIR.glob("*/scene*.xml"))
REQUIRED_FILES = ("README.md", "LICENSE", "CHANGELOG.md")
N_STEPS = 500
HOLD_STEPS = 50  # steps between two pseudorandom commands


def _relative(path: Path) -> str:
    """Test id of a model path: its path under models/.

    Args:
        path: A folder or file under models/.

    Returns:
        The path relative to models/, with forward slashes.
    """
    return path.relative_to(MODELS_DIR).as_posix()


def test_there_are_model_folders_and_scenes():
    assert len(MODEL_DIRS) >= 2  # abb_irb360 and cell
    assert len(SCENE_FILES) >= len(MODEL_DIRS)


@pytest.mark.parametrize("folder", MODEL_DIRS, ids=_relative)
def test_model_folder_holds_readme_license_changelog_and_a_scene(folder):
    missing = [name for name in REQUIRED_FILES if not (folder / name).is_file()]
    assert missing == []
    assert sorted(folder.glob("scene*.xml")) != []
    assert "Apache License" in (folder / "LICENSE").read_text()


@pytest.mark.parametrize("path", SCENE_FILES, ids=_relative)
def test_scene_compiles_and_steps_under_random_controls_without_warnings(path):
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if home >= 0:
        mujoco.mj_resetDataKeyframe(model, data, home)
    rng = np.random.default_rng(0)
    lo, hi = model.actuator_ctrlrange.T
    for step in range(N_STEPS):
        if step % HOLD_STEPS == 0:
            data.ctrl[:] = rng.uniform(lo, hi)
        mujoco.mj_step(model, data)
    counts = {mujoco.mjtWarning(i).name: w.number for i, w in enumerate(data.warning) if w.number}
    assert counts == {}
    assert np.all(np.isfinite(data.qpos))
    assert data.time == pytest.approx(N_STEPS * model.opt.timestep, rel=1e-9)
