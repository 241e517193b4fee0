"""docs/envs.md's examples run as written: the vector environments' always, MaskablePPO's where
sb3-contrib is installed (the optional extra `rl`)."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest

from sim.paths import REPO_ROOT

DOC = REPO_ROOT / "docs" / "envs.md"


def _block(marker: str) -> str:
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)
    return next(b for b in blocks if marker in b)


def _run(code: str, tmp_path) -> subprocess.CompletedProcess:
    script = tmp_path / "example.py"
    script.write_text(code)
    env = {**os.environ, "PYTHONPATH": str(REPO_ROOT)}
    return subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=600
    )


def test_the_vector_environment_example_runs(tmp_path):
    done = _run(_block("AsyncVectorEnv") + "\nprint('steps done', obs.shape)\n", tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "steps done (2, 72)" in done.stdout


def test_the_maskable_ppo_example_runs(tmp_path):
    pytest.importorskip("sb3_contrib")
    done = _run(_block("MaskablePPO"), tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "profit per belt" in done.stdout
