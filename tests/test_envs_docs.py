"""docs/envs.md's examples: the vector environments' runs as written; MaskablePPO's needs the
optional extra `rl` (sb3-contrib and torch, never installed by the test extra), so what it relies
on is checked here without them."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import gymnasium as gym
import numpy as np
from gymnasium.wrappers import RecordEpisodeStatistics

import sim.envs  # noqa: F401  (registers the ids)
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


def test_the_maskable_ppo_example_is_python_on_the_environment_it_names():
    code = _block("MaskablePPO")
    compile(code, str(DOC), "exec")
    assert 'gym.make("sortsim/PickOrder-v0")' in code
    assert "env.unwrapped.action_masks()" in code and "use_masking=True" in code


def test_masked_decisions_run_belts_to_their_end_through_a_wrapper():
    """What MaskablePPO does with the environment, without torch: through a wrapper (the
    example's Monitor), it finds `action_masks` by `get_wrapper_attr`, takes only actions the
    mask allows (an untrained policy: any of them), and resets when a belt ends."""
    env = RecordEpisodeStatistics(gym.make("sortsim/PickOrder-v0"))
    rng = np.random.default_rng(0)
    obs, info = env.reset(seed=0)
    ends = 0
    for _ in range(384):  # the example's total_timesteps
        mask = env.get_wrapper_attr("action_masks")()
        assert mask.dtype == bool and mask.shape == (env.action_space.n,) and mask[-1]
        assert np.array_equal(mask, info["action_mask"])
        assert env.observation_space.contains(obs)
        obs, _, terminated, truncated, info = env.step(int(rng.choice(np.flatnonzero(mask))))
        if terminated or truncated:
            ends += 1
            assert info["episode"]["l"] > 0
            obs, info = env.reset()
    assert ends >= 3  # the example evaluates three belts
