"""manifest.json: a run's and a sweep's folder say what made them (config, seeds, versions,
commit, machine, command); `sortsim --version`."""

from __future__ import annotations

import json
import subprocess
import sys

import mujoco

import sim
from sim.cli.sweep import seeds, sweep_manifest_config
from sim.episode import config as episode_config
from sim.episode import manifest
from sim.experiments import sweep_config
from sim.paths import REPO_ROOT
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
    resolved = sweep_manifest_config(config)
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
