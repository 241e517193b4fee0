"""Output files get a normal file's mode (0o666 less the umask), not a temporary file's 0o600.

`write_atomic` writes through `tempfile.mkstemp`, which creates its file readable by its owner
only, and renames it over the target; the target must end up with the mode any other new file
of the process gets: 0o666 & ~umask (0o644 under the usual 022, 0o664 under 002, 0o640 under
027). Each umask is set for the test and restored after it; the files' modes are compared with
a file created the ordinary way in the same folder.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from sim.results import outputs

UMASKS = (0o022, 0o002, 0o027, 0o077)


@pytest.fixture(params=UMASKS, ids=[f"umask{m:03o}" for m in UMASKS])
def umask(request):
    """The process umask set to the parameter for the test, then restored."""
    old = os.umask(request.param)
    try:
        yield request.param
    finally:
        os.umask(old)


def mode(path: Path) -> int:
    """Permission bits of `path`."""
    return stat.S_IMODE(path.stat().st_mode)


def ordinary_mode(folder: Path) -> int:
    """Mode of a file created with open() in `folder` under the current umask."""
    probe = folder / "ordinary.txt"
    probe.write_text("x", encoding="utf-8")
    try:
        return mode(probe)
    finally:
        probe.unlink()


def test_write_atomic_text_and_bytes_get_the_umask_mode(tmp_path, umask):
    expected = 0o666 & ~umask
    assert ordinary_mode(tmp_path) == expected
    text = outputs.write_atomic(tmp_path / "a.txt", "hello\n")
    blob = outputs.write_atomic(tmp_path / "deeper" / "b.bin", b"\x00\x01")
    assert mode(text) == expected, oct(mode(text))
    assert mode(blob) == expected, oct(mode(blob))
    assert text.read_text(encoding="utf-8") == "hello\n" and blob.read_bytes() == b"\x00\x01"
    # Only the targets are left: no temporary file beside them.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "deeper"]
    assert [p.name for p in (tmp_path / "deeper").iterdir()] == ["b.bin"]


def test_episode_and_pick_csvs_get_the_umask_mode(tmp_path, umask):
    expected = 0o666 & ~umask
    row = {c: 0 for c in outputs.EPISODE_COLUMNS}
    episodes = outputs.write_episodes(tmp_path / "episodes.csv", [row])
    picks = outputs.write_picks(tmp_path / "picks.csv", [])
    appended = outputs.append_episode(tmp_path / "more" / "episodes.csv", row)
    for path in (episodes, picks, appended):
        assert mode(path) == expected, (path.name, oct(mode(path)))
    assert len(outputs.read_rows(appended)) == 1


def test_a_rewrite_gives_the_umask_mode_whatever_the_old_file_had(tmp_path):
    old = os.umask(0o022)
    try:
        path = tmp_path / "episodes.csv"
        path.write_text("old\n", encoding="utf-8")
        path.chmod(0o600)
        row = {c: 1 for c in outputs.EPISODE_COLUMNS}
        outputs.append_episode(path, row)  # the file is rewritten through a temporary one
        assert mode(path) == 0o644, oct(mode(path))
        outputs.append_episode(path, row)
        assert mode(path) == 0o644 and len(outputs.read_rows(path)) == 2
    finally:
        os.umask(old)


def test_the_umask_is_left_as_it_was(tmp_path, umask):
    outputs.write_atomic(tmp_path / "c.txt", "x")
    now = os.umask(0o022)
    os.umask(now)
    assert now == umask
