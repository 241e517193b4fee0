"""Where sortsim keeps what it computes once and reuses: the user's cache folder.

The stripe HMMs, the item classifier, the belt camera's lens maps, a catalogue's recorded
training table and results that could not be written to their folder are kept under one
folder of the user's, never inside the install (a read-only or shared install runs; a run
leaves the checkout as it was):

- `SORTSIM_CACHE_DIR` when set: an absolute path (a relative one would name another folder
  for each working directory a process starts in);
- else the platform's cache folder: `$XDG_CACHE_HOME/sortsim` (an absolute XDG_CACHE_HOME) or
  `~/.cache/sortsim` on Linux and other Unix systems, `~/Library/Caches/sortsim` on macOS,
  `%LOCALAPPDATA%\\sortsim\\cache` on Windows.

The folder is created private to its user (mode 0o700; an existing folder is used as it is),
and tried before use: a path that is a file, lies under one, or cannot be written is refused in
one line naming `SORTSIM_CACHE_DIR`. Its files are rebuilt when missing: deleting the folder
costs only the time to make them again (seconds; minutes for another catalogue's table).

The item classifier's cache is a pickle, and loading a pickle runs whatever code it names, so
it is read only through `open_own_file`: a regular file (not a symbolic link) of this user's
that no one else can write; anything else is refused in one line. The other caches are plain
arrays read without pickles (`numpy.load`'s default).
"""

from __future__ import annotations

import os
import stat
import sys
from pathlib import Path

from sim.errors import InvalidInput
from sim.paths import temporary_path

VARIABLE = "SORTSIM_CACHE_DIR"
WHERE = "the environment"
APP = "sortsim"
PRIVATE_MODE = 0o700
"""Mode of the cache folder when sortsim creates it: its user's only."""
ALLOWED = "an absolute path of a folder sortsim can create and write"
DEFAULT_TEXT = (
    "$XDG_CACHE_HOME/sortsim, else ~/.cache/sortsim (Linux and other Unix systems); "
    "~/Library/Caches/sortsim (macOS); %LOCALAPPDATA%\\sortsim\\cache (Windows)"
)
MEANING = (
    "Where the stripe HMMs, the item classifier, the belt camera's lens maps, another "
    "catalogue's training table and results that could not be written are kept between runs "
    "(never inside the install); created private to its user (mode 0o700). Deleting it costs "
    "only the time to make them again."
)
"""`docs/settings.md`'s row of the variable (`sim.experiments.settings_doc`)."""

_ready: set[Path] = set()
"""Folders tried (written to) by this process: tried again only when they have gone."""


def default_cache_dir(platform: str = sys.platform, environ=os.environ) -> Path:
    """The platform's cache folder for sortsim (`SORTSIM_CACHE_DIR` not considered).

    Args:
        platform: `sys.platform`'s value ("linux", "darwin", "win32", ...).
        environ: The environment (XDG_CACHE_HOME, LOCALAPPDATA, HOME).
    """
    home = Path(environ.get("HOME") or Path.home())
    if platform == "win32":
        local = environ.get("LOCALAPPDATA", "")
        base = Path(local) if local and Path(local).is_absolute() else home / "AppData" / "Local"
        return base / APP / "cache"
    if platform == "darwin":
        return home / "Library" / "Caches" / APP
    xdg = environ.get("XDG_CACHE_HOME", "")
    base = Path(xdg) if xdg and Path(xdg).is_absolute() else home / ".cache"
    return base / APP


def cache_location() -> Path:
    """Where the cache folder is, created or not (`SORTSIM_CACHE_DIR`, else the platform's).

    Raises:
        InvalidInput: `SORTSIM_CACHE_DIR` is not an absolute path.
    """
    value = os.environ.get(VARIABLE, "")
    if not value:
        return default_cache_dir()
    if "\0" in value or not Path(value).is_absolute():
        raise InvalidInput(VARIABLE, ALLOWED, value, WHERE)
    return Path(value)


def cache_dir() -> Path:
    """The cache folder, created private to its user if need be and tried once a process.

    Raises:
        InvalidInput: The folder cannot be used (a file, under a file, not writable), in one
            line naming `SORTSIM_CACHE_DIR`.
    """
    path = cache_location()
    if path in _ready and path.is_dir():
        return path
    _make_private(path)
    _ready.add(path)
    return path


def existing_cache_dir() -> Path | None:
    """The cache folder when it exists, None otherwise (nothing created, nothing refused)."""
    try:
        path = cache_location()
    except InvalidInput:
        return None
    return path if path.is_dir() else None


def _make_private(path: Path) -> None:
    """Create `path` (mode 0o700; its missing parents with the usual mode), then create and
    remove a probe file in it (permissions alone do not tell: root passes `os.access` on a
    read-only file system); refuse it in one line when either fails."""
    if path.exists() and not path.is_dir():
        raise _unusable(path, "an existing file")
    probe = temporary_path(path / "sortsim-probe")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.mkdir(mode=PRIVATE_MODE, exist_ok=True)
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        probe.unlink()
    except OSError as exc:
        raise _unusable(path, _reason(exc)) from None


def _unusable(path: Path, reason: str) -> InvalidInput:
    """The refusal of cache folder `path` (given, or the platform's when the variable is
    unset: then setting it is the way out)."""
    given = os.environ.get(VARIABLE)
    allowed = ALLOWED if given else f"{ALLOWED} (unset: the platform's cache folder)"
    return InvalidInput(VARIABLE, allowed, f"{path}: {reason}", WHERE)


def _reason(exc: OSError) -> str:
    if isinstance(exc, (FileExistsError, NotADirectoryError)):
        return "a file lies on its path"
    return exc.strerror or type(exc).__name__


def open_own_file(path: Path | str, field: str):
    """`path` opened for reading in binary, when it is a regular file of this user's that no
    one else can write (the checks made on the open file, so the file checked is the file read;
    a symbolic link is not followed). For files whose loading runs code (pickles).

    Args:
        path: The file.
        field: What it is, for the refusal ("item classifier cache").

    Raises:
        FileNotFoundError: There is no such file.
        InvalidInput: Anything else, in one line naming the file and how to go on.
    """
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        raise
    except OSError as exc:
        problem = "a symbolic link" if os.path.islink(path) else _reason(exc)
        raise InvalidInput(field, _TRUSTED, problem, str(path)) from None
    try:
        found = foreign_file_problem(os.fstat(fd))
    except BaseException:
        os.close(fd)
        raise
    if found is not None:
        os.close(fd)
        raise InvalidInput(field, _TRUSTED, found, str(path))
    return os.fdopen(fd, "rb")


_TRUSTED = (
    "a regular file of this user's that no other user can write (loading it runs code; "
    "delete it to make it afresh)"
)


def foreign_file_problem(status: os.stat_result, uid: int | None = None) -> str | None:
    """Why a file of `status` may not be trusted to run code, None when it may: not a regular
    file, owned by another user than `uid` (this process's), or writable by its group or by
    others. Ownership is not checked where the platform has no user ids (Windows).
    """
    if not stat.S_ISREG(status.st_mode):
        return "not a regular file"
    if uid is None and hasattr(os, "geteuid"):
        uid = os.geteuid()
    if uid is not None and status.st_uid != uid:
        return f"owned by user id {status.st_uid}, not {uid}"
    if status.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f"writable by others (mode {stat.S_IMODE(status.st_mode):o})"
    return None
