"""Results traceable to their code: the code digest (stable, one byte changes it, docs and
caches do not), each episode's row carrying it, a sweep resumed on other code refused in one
line with its folder untouched, `--mix-code` topping it up, and a reproduce block saying so.

The other code is real: a copy of the package with one source byte changed runs a sweep in a
process of its own; this process's code then meets its folder."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from sim.cli.main import main
from sim.errors import InvalidInput
from sim.experiments.thesis import reproduce
from sim.experiments.thesis.reproduce import Run
from sim.paths import REPO_ROOT
from sim.results import code_digest, outputs

TINY = """[sweep]
name = "{name}"
speed_factors = [1.0]
items = [3]
planners = ["{planner}"]
seeds = 2

[base]
perception = "truth"
duration_s = 3.0
"""
ONE_BYTE = ('"""The thesis\'s comparison picker', '"""the thesis\'s comparison picker')
"""The byte changed in the copy (planner/decision/managers/proximity.py's first letter)."""


def _copy_code(to: Path) -> Path:
    """The code roots copied to `to` (no caches), one byte of one source file changed."""
    for root in code_digest.CODE_ROOTS:
        shutil.copytree(
            REPO_ROOT / root, to / root, ignore=shutil.ignore_patterns("__pycache__", ".*")
        )
    source = to / "planner" / "decision" / "managers" / "proximity.py"
    text = source.read_text()
    assert text.count(ONE_BYTE[0]) == 1
    source.write_text(text.replace(*ONE_BYTE))
    return to


@pytest.fixture(scope="module")
def other_code(tmp_path_factory):
    """(copy, its digest, a sweep folder of 1 episode of 2 it ran, the sweep file)."""
    root = tmp_path_factory.mktemp("digest")
    copy = _copy_code(root / "code")
    experiments = root / "experiments"
    experiments.mkdir()
    config = experiments / "reproduce_4_5.toml"
    config.write_text(TINY.format(name="reproduce_4_5", planner="proximity"))
    out = root / "out" / "reproduce_4_5"
    proc = subprocess.run(
        [sys.executable, "-m", "sim.cli.main", "sweep", "--config", str(config)]
        + ["--out", str(out), "--workers", "1", "--seeds", "1"],
        cwd=copy,
        env={**os.environ, "PYTHONPATH": str(copy)},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    return copy, code_digest.digest_of(copy), out, config


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def test_the_digest_is_of_the_files_and_one_byte_changes_it(tmp_path, other_code):
    copy, theirs, _, _ = other_code
    ours = code_digest.code_digest()
    assert len(ours) == code_digest.DIGEST_HEX and ours == code_digest.digest_of(REPO_ROOT)
    assert theirs != ours
    # The copy with its byte put back is this code again; docs and caches do not count.
    source = copy / "planner" / "decision" / "managers" / "proximity.py"
    back = tmp_path / "back"
    shutil.copytree(copy, back, ignore=shutil.ignore_patterns("runs"))
    (back / source.relative_to(copy)).write_text(source.read_text().replace(*ONE_BYTE[::-1]))
    assert code_digest.digest_of(back) == ours
    (back / "sim" / "NOTES.md").write_text("a doc\n")
    (back / "sim" / "__pycache__").mkdir(exist_ok=True)
    (back / "sim" / "__pycache__" / "x.cpython-312.pyc").write_bytes(b"\0")
    (back / "sim" / ".x.py.123.abcdef01.tmp").write_text("a temporary\n")
    assert code_digest.digest_of(back) == ours
    (back / "sim" / "data" / "items.toml").write_bytes(
        (back / "sim" / "data" / "items.toml").read_bytes() + b"\n"
    )
    assert code_digest.digest_of(back) != ours  # data the episodes read counts
    assert code_digest.git_commit(back) is None  # no git checkout: no commit, no failure
    assert code_digest.commit_text(None) == "no git commit"


def test_every_episode_row_keeps_its_digest(other_code):
    _, theirs, out, _ = other_code
    rows = outputs.read_rows(out / "episodes.csv")
    assert [r["code_digest"] for r in rows] == [theirs]
    header = (out / "episodes.csv").read_text().splitlines()[0].split(",")
    assert "code_digest" in header and "code_digest" in outputs.EPISODE_COLUMNS


def test_a_sweep_resumed_on_other_code_is_refused_and_its_folder_untouched(
    tmp_path, other_code, capsys
):
    _, theirs, made, config = other_code
    out = tmp_path / "sweep"
    shutil.copytree(made, out)
    before = _snapshot(out)
    args = ["sweep", "--config", str(config), "--out", str(out), "--workers", "1"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    ours = code_digest.code_digest()
    assert len(err.splitlines()) == 1, err
    assert "--out" in err and "--mix-code" in err and theirs in err and ours in err
    assert _snapshot(out) == before  # byte for byte, nothing added
    # Knowingly: the pending seed runs on this code beside the other code's episode.
    assert main([*args, "--mix-code"]) == 0
    rows = outputs.read_rows(out / "episodes.csv")
    assert sorted((r["seed"], r["code_digest"]) for r in rows) == [("0", theirs), ("1", ours)]


def test_reproduce_refuses_other_code_before_any_work_and_a_mixed_block_says_so(
    tmp_path, other_code
):
    _, theirs, made, config = other_code
    experiments = tmp_path / "experiments"
    experiments.mkdir()
    shutil.copy(config, experiments)
    (experiments / "reproduce_4_5_random.toml").write_text(
        TINY.format(name="reproduce_4_5_random", planner="random")
    )
    out = tmp_path / "out"
    shutil.copytree(made, out / "reproduce_4_5")
    before = _snapshot(out / "reproduce_4_5")

    def run(**kw):
        return Run(out, quick=True, workers=1, experiments=experiments, **kw)

    with pytest.raises(InvalidInput) as err:
        reproduce.reproduce(["table_4_5"], run(), None, echo=lambda _: None)
    assert "--mix-code" in str(err.value) and theirs in str(err.value)
    assert _snapshot(out / "reproduce_4_5") == before
    assert not (out / "reproduce_4_5_random").exists() and not (out / "table_4_5.md").exists()
    made_blocks = reproduce.reproduce(["table_4_5"], run(mix_code=True), None, echo=lambda _: None)
    first = made_blocks["table_4_5"].markdown.splitlines()[0]
    ours = code_digest.code_digest()
    assert first.startswith("*Generated by `sortsim reproduce --only table_4_5 --quick --mix-code`")
    assert f"code digest {ours}; MIXED CODE: its episodes ran on code digests " in first
    assert f"{theirs} (1 episode)" in first and f"{ours} (1 episode)" in first
