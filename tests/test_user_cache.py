"""The user's cache folder (`sim.user_cache`): where it is, created private to its user, a bad
one refused in one line naming `SORTSIM_CACHE_DIR`; the item classifier's pickle read only from
a file of this user's that no one else can write; a camera run writes nothing into the
checkout, and runs from a read-only one."""

from __future__ import annotations

import contextlib
import json
import os
import pathlib
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from sim.cli.main import main
from sim.errors import InvalidInput
from sim.paths import REPO_ROOT
from sim.sensing import item_classifier
from sim.user_cache import (
    VARIABLE,
    cache_dir,
    default_cache_dir,
    existing_cache_dir,
    foreign_file_problem,
    open_own_file,
)

CAMERA_RUN = ["run", "--perception", "camera", "--items", "3", "--duration", "2", "--quiet"]
"""A camera episode of a few seconds of CPU (3 items, every one picked)."""
PACKAGE = ("sim", "perception", "planner", "models")
"""What a camera episode reads of the install (code, data, models)."""
OTHER_USER = 65534
"""A user id not this process's (`nobody` on most systems)."""


def test_the_platforms_cache_folder():
    home = {"HOME": "/home/ann"}
    assert default_cache_dir("linux", home) == Path("/home/ann/.cache/sortsim")
    xdg = {**home, "XDG_CACHE_HOME": "/var/cache/ann"}
    assert default_cache_dir("linux", xdg) == Path("/var/cache/ann/sortsim")
    relative = {**home, "XDG_CACHE_HOME": "cache"}  # ignored, as the XDG spec says
    assert default_cache_dir("freebsd14", relative) == Path("/home/ann/.cache/sortsim")
    assert default_cache_dir("darwin", home) == Path("/home/ann/Library/Caches/sortsim")
    local = {**home, "LOCALAPPDATA": "/c/Users/ann/AppData/Local"}
    assert default_cache_dir("win32", local) == Path("/c/Users/ann/AppData/Local/sortsim/cache")
    assert default_cache_dir("win32", home) == Path("/home/ann/AppData/Local/sortsim/cache")


def test_the_cache_folder_is_made_private_where_the_variable_says(tmp_path, monkeypatch):
    folder = tmp_path / "shared" / "ann" / "sortsim"
    monkeypatch.setenv(VARIABLE, str(folder))
    assert existing_cache_dir() is None  # nothing made by asking where it is
    assert cache_dir() == folder
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    assert list(folder.iterdir()) == []  # the probe file removed
    shutil.rmtree(tmp_path / "shared")
    assert cache_dir() == folder and folder.is_dir()  # made again when it has gone
    assert existing_cache_dir() == folder
    monkeypatch.delenv(VARIABLE)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("XDG_CACHE_HOME", "")
    assert cache_dir() == tmp_path / "home" / ".cache" / "sortsim"


@contextlib.contextmanager
def read_only(folder: Path, fill=None):
    """`folder`, filled by `fill(folder)`, then made read-only: a tmpfs remounted read-only when
    this process is root (root writes through a folder's modes), its modes otherwise."""
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        if fill:
            fill(folder)
        _chmod_tree(folder, writable=False)
        try:
            yield folder
        finally:
            _chmod_tree(folder, writable=True)
        return
    _mount("-t", "tmpfs", "-o", "size=64m", "tmpfs", folder)
    try:
        if fill:
            fill(folder)
        _mount("-o", "remount,ro", folder)
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], capture_output=True)


def _mount(*args) -> None:
    if shutil.which("mount") is None:
        pytest.skip("a read-only folder for root needs mount(8)")
    proc = subprocess.run(["mount", *map(str, args)], capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.skip(f"mounting a tmpfs is not permitted here: {proc.stderr.strip()}")


def _chmod_tree(folder: Path, writable: bool) -> None:
    for path in [folder, *folder.rglob("*")]:
        mode = path.stat().st_mode
        path.chmod(mode | stat.S_IWUSR if writable else mode & ~0o222)


@pytest.mark.parametrize("case", ["relative", "a file", "under a file", "read-only"])
def test_a_cache_folder_that_cannot_be_used_is_refused_before_the_episode(
    tmp_path, monkeypatch, capfd, case
):
    (tmp_path / "file").write_text("not a folder\n")
    out = tmp_path / "out"
    given = {
        "relative": Path("cache"),
        "a file": tmp_path / "file",
        "under a file": tmp_path / "file" / "cache",
        "read-only": tmp_path / "ro" / "cache",
    }[case]
    monkeypatch.setenv(VARIABLE, str(given))
    with read_only(tmp_path / "ro") if case == "read-only" else contextlib.nullcontext():
        code = main([*map(str, CAMERA_RUN), "--out", str(out)])
    lines = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1, lines
    assert lines[0].startswith(f"sortsim run: {VARIABLE} in the environment: allowed an absolute")
    assert str(given) in lines[0]
    assert not out.exists()  # refused before the episode, nothing written


class Marker:
    """A pickle that, loaded, creates `path`: loading a pickle runs the code it names."""

    def __init__(self, path: Path):
        self.path = path

    def __reduce__(self):
        return (pathlib.Path.touch, (self.path,))


@pytest.fixture
def classifier_cache(tmp_path, monkeypatch):
    """The item classifier's cache file in a cache folder of this test's, holding a `Marker`
    (written by the classifier's own writer) instead of a fitted classifier."""
    monkeypatch.setenv(VARIABLE, str(tmp_path / "cache"))
    item_classifier._fitted.cache_clear()
    path = item_classifier._cache_path(item_classifier.TRAINING_TABLE)
    item_classifier._keep(path, Marker(tmp_path / "loaded"))
    yield path
    item_classifier._fitted.cache_clear()


def test_the_classifier_cache_is_written_private_and_loaded_when_this_users(
    classifier_cache, tmp_path
):
    assert classifier_cache.parent == tmp_path / "cache"
    assert stat.S_IMODE(classifier_cache.stat().st_mode) == 0o600
    assert [p.name for p in classifier_cache.parent.iterdir()] == [classifier_cache.name]
    item_classifier.trained_item_classifier()
    assert (tmp_path / "loaded").exists()  # read by the camera's own path
    classifier_cache.chmod(0o644)  # others may read it: still loaded
    assert foreign_file_problem(classifier_cache.stat()) is None


def _refused_unloaded(path: Path, tmp_path: Path, problem: str) -> None:
    with pytest.raises(InvalidInput) as refusal:
        item_classifier.trained_item_classifier()
    line = str(refusal.value)
    assert "\n" not in line and str(path) in line and problem in line, line
    assert line.startswith("item classifier cache in ") and "delete it" in line
    assert not (tmp_path / "loaded").exists()  # never unpickled


def test_a_classifier_cache_others_can_write_is_refused_unloaded(classifier_cache, tmp_path):
    for mode in (0o620, 0o602, 0o666):
        classifier_cache.chmod(mode)
        _refused_unloaded(classifier_cache, tmp_path, "writable by others")
    classifier_cache.chmod(0o600)
    link = classifier_cache.with_name("kept.pkl")
    classifier_cache.rename(link)
    classifier_cache.symlink_to(link)
    _refused_unloaded(classifier_cache, tmp_path, "a symbolic link")


def test_a_classifier_cache_another_user_owns_is_refused_unloaded(classifier_cache, tmp_path):
    other = os.geteuid() + 1
    assert f"owned by user id {os.geteuid()}" in foreign_file_problem(
        classifier_cache.stat(), uid=other
    )
    if os.geteuid() != 0:
        pytest.skip("giving a file to another user needs root (the check itself passed above)")
    os.chown(classifier_cache, OTHER_USER, -1)
    _refused_unloaded(classifier_cache, tmp_path, f"owned by user id {OTHER_USER}")
    with pytest.raises(InvalidInput), open_own_file(classifier_cache, "a pickle"):
        pass


def test_a_camera_run_refuses_a_classifier_cache_others_can_write(
    classifier_cache, tmp_path, capfd
):
    classifier_cache.chmod(0o666)
    out = tmp_path / "out"
    code = main([*map(str, CAMERA_RUN), "--out", str(out)])
    lines = capfd.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1, lines
    assert str(classifier_cache) in lines[0] and "writable by others" in lines[0]
    assert not out.exists() and not (tmp_path / "loaded").exists()


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    """Every file and folder under `root` with its size and modification time, leaving out
    git's own folder and Python's and the tools' caches (written by other tests' imports)."""
    skip = {".git", "__pycache__", ".pytest_cache", ".ruff_cache"}
    out = {}
    for folder, names, files in os.walk(root):
        names[:] = [n for n in names if n not in skip]
        for name in names + [f for f in files if f != ".git"]:
            path = Path(folder, name)
            status = path.lstat()
            out[str(path.relative_to(root))] = (status.st_size, status.st_mtime_ns)
    return out


def _camera_run(code_root: Path, cache: Path, out: Path) -> dict:
    """A camera episode of the code at `code_root` (its working folder); its manifest."""
    env = {
        **os.environ,
        "MUJOCO_GL": "egl",
        "PYOPENGL_PLATFORM": "egl",
        VARIABLE: str(cache),
        "PYTHONDONTWRITEBYTECODE": "1",
    }
    proc = subprocess.run(
        [sys.executable, "-m", "sim.cli", *CAMERA_RUN, "--out", str(out)],
        cwd=code_root,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads((out / "manifest.json").read_text())


def test_a_camera_run_writes_nothing_into_the_checkout(tmp_path):
    before = _tree(REPO_ROOT)
    cache = cache_dir()  # the suite's (conftest.py): the caches made once a session
    manifest = _camera_run(REPO_ROOT, cache, tmp_path / "out")
    assert manifest["command"][0].startswith(str(REPO_ROOT))
    assert _tree(REPO_ROOT) == before
    names = {p.name.split("-")[0] for p in cache.iterdir()}
    assert {"stripe_hmms", "item_classifier", "lens_maps"} <= names


def _copy_package(root: Path) -> None:
    for name in PACKAGE:
        shutil.copytree(REPO_ROOT / name, root / name, ignore=shutil.ignore_patterns(".*"))


def test_a_read_only_checkout_runs_a_camera_episode(tmp_path):
    """The install copied and made read-only, the cache folder new: the run makes every cache
    in it, and the copy is as it was."""
    cache = tmp_path / "user" / "cache"
    with read_only(tmp_path / "install", _copy_package) as install:
        before = _tree(install)
        manifest = _camera_run(install, cache, tmp_path / "out")
        assert _tree(install) == before
    assert manifest["command"][0].startswith(str(install))  # the copy's code ran
    assert manifest["git"] is None
    rows = (tmp_path / "out" / "episodes.csv").read_text().splitlines()
    assert len(rows) == 2 and rows[1].startswith("0,qlearning,")
    assert stat.S_IMODE(cache.stat().st_mode) == 0o700
    assert {p.name.split("-")[0] for p in cache.iterdir()} == {
        "item_classifier",
        "lens_maps",
        "stripe_hmms",
    }
    assert stat.S_IMODE(next(cache.glob("item_classifier-*.pkl")).stat().st_mode) == 0o600
