"""manifest.json: a run's and a sweep's folder say what made them (config, seeds, versions,
commit, machine, command); `sortsim --version`."""

from __future__ import annotations

import json
import subprocess
import sys

import mujoco
import pytest

import sim
from sim import config as episode_config
from sim.errors import InvalidInput
from sim.experiments import sweep_config
from sim.experiments.sweep_runner import manifest_config, seeds
from sim.paths import REPO_ROOT
from sim.results import manifest
from tests.test_cli_run import run_dir  # noqa: F401  (the module's `sortsim run` fixture)


def test_a_run_folder_has_its_manifest(run_dir):  # noqa: F811
    out, _ = run_dir
    data = json.loads((out / "manifest.json").read_text())
    assert data["kind"] == "run" and data["format"] == manifest.FORMAT
    assert data["seeds"] == [2]
    # The whole resolved config: the file's keys, the command line's overrides, the defaults.
    expected = episode_config.load(
        out / "cell.toml", seed=2, items=4, duration_s=3.0, perception="truth", planner="greedy"
    )
    assert data["config"] == json.loads(json.dumps(expected.to_dict()))
    assert data["config"]["video"]["width"] == 320
    assert data["mujoco_version"] == mujoco.__version__
    assert data["sortsim_version"] == sim.__version__
    assert data["command"][-1] == "--quiet"
    assert data["machine"]["cores"] >= 1 and data["machine"]["cpu"]
    if (REPO_ROOT / ".git").exists():
        assert len(data["git"]["commit"]) == 40


def test_a_sweep_manifest_lists_every_grid_point_once():
    config = sweep_config.load(REPO_ROOT / "experiments" / "table_4_5.toml")
    resolved = manifest_config(config)
    # 5 item counts x 2 planners, 10 seeds each: 10 grid points, seeds kept apart.
    assert len(resolved["grid"]) == 10
    assert all("seed" not in point["config"] for point in resolved["grid"])
    assert {p["config"]["planner"] for p in resolved["grid"]} == {"proximity", "qlearning"}
    assert sorted(set(seeds(config))) == list(range(10))
    assert resolved["identity"] == config.identity
    json.dumps(manifest.build("sweep", resolved, seeds(config)))  # JSON-ready


def test_version_option():
    proc = subprocess.run(
        [sys.executable, "-m", "sim.cli.main", "--version"], capture_output=True, text=True
    )
    assert proc.returncode == 0
    assert proc.stdout.strip() == f"sortsim {sim.__version__}"


def test_a_run_repeats_byte_for_byte_from_its_manifest(tmp_path):
    """`sortsim run --config <folder>/manifest.json` runs the same episode again: the CSVs are
    the same bytes (the wall-clock columns aside), with a custom catalogue, class mix and
    values; a manifest whose catalogue file changed since is refused in one line."""
    import shutil

    from sim.cli.main import main
    from sim.paths import REPO_ROOT
    from sim.results import outputs

    catalogue = tmp_path / "pet_hdpe.toml"
    shutil.copy(REPO_ROOT / "experiments" / "catalogues" / "pet_hdpe.toml", catalogue)
    config = tmp_path / "four.toml"
    text = (REPO_ROOT / "experiments" / "four_materials.toml").read_text()
    config.write_text(text.replace("experiments/catalogues/pet_hdpe.toml", str(catalogue)))
    first, again = tmp_path / "first", tmp_path / "again"
    common = ["--perception", "truth", "--items", "12", "--duration", "12", "--quiet"]
    assert main(["run", "--config", str(config), "--seed", "7", "--out", str(first), *common]) == 0
    assert main(["run", "--config", str(first / "manifest.json"), "--out", str(again)]) == 0
    for name in ("episodes.csv", "picks.csv"):
        a, b = (outputs.strip_wall_clock((d / name).read_text()) for d in (first, again))
        assert a == b, name
    assert (first / "picks.csv").read_bytes() == (again / "picks.csv").read_bytes()
    assert (
        json.loads((again / "manifest.json").read_text())["config"]
        == json.loads((first / "manifest.json").read_text())["config"]
    )
    catalogue.write_text(catalogue.read_text().replace("value_eur = 0.30", "value_eur = 0.31"))
    with pytest.raises(InvalidInput) as err:
        episode_config.load(first / "manifest.json")
    assert err.value.field == "catalogue" and "changed since" in str(err.value)
