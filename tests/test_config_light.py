"""Reading a config imports neither OpenCV nor MuJoCo: an episode's TOML (`sim.config.load`) and a
sweep's (`experiments/table_4_5.toml`) are checked in a fresh interpreter, where nothing else
has imported them."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
_CHILD = """
import json, sys
import sim.config
config = sim.config.load({episode!r})
episode = sorted(m for m in ("cv2", "mujoco") if m in sys.modules)
from sim.experiments import sweep_config
sweep = sweep_config.load({sweep!r})
print(json.dumps({{
    "episode": episode,
    "sweep": sorted(m for m in ("cv2", "mujoco") if m in sys.modules),
    "items": config.items,
    "episodes": len(sweep.episodes),
}}))
"""


def test_loading_an_episode_and_a_sweep_config_imports_neither_cv2_nor_mujoco(tmp_path):
    path = tmp_path / "episode.toml"
    path.write_text(
        'items = 7\nplanner = "fifo"\n[belt]\nwidth_m = 0.6\n[robot]\npick_pause_s = 0.5\n'
    )
    code = _CHILD.format(episode=str(path), sweep=str(REPO / "experiments" / "table_4_5.toml"))
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    assert report["items"] == 7 and report["episodes"] > 0, report
    assert report["episode"] == [], report
    assert report["sweep"] == [], report
