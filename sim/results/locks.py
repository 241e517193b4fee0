"""One command at a time in an output folder: an advisory lock held while a run or sweep uses it.

`sortsim run` and `sortsim sweep` hold `FolderLock(out)` from before their first episode until
their files are written: an exclusive, non-blocking `fcntl.flock` on a lock file inside the
folder (`LOCK_FILE`). A second command into the same folder finds it taken and is refused in one
line naming the folder and the process holding it (`InvalidInput`, exit code 2), before any
work; two runs or two sweeps never write into one folder at once, so no folder mixes two runs.

The kernel drops the lock when its process ends, however it ends (a `kill -9` too), so a stale
lock file never blocks the next command. The file is removed when the lock is let go (the lock
is checked to still be on the file at that path after it is taken, so removing it races with
nobody); it is hidden, holds only the process id, is not an output, and `sortsim report` and a
sweep's resume ignore it.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from pathlib import Path

from sim.errors import InvalidInput

LOCK_FILE = ".sortsim.lock"
"""The lock file's name inside a locked output folder."""
_ATTEMPTS = 20


class FolderLock:
    """The exclusive lock of an output folder (a context manager).

    Args:
        folder: The output folder (created when the lock is taken).
        field: The option that named it, for the refusal ("--out").
    """

    def __init__(self, folder: Path | str, field: str = "--out"):
        self.folder = Path(folder)
        self.field = field
        self.path = self.folder / LOCK_FILE
        self._fd: int | None = None

    def __enter__(self) -> FolderLock:
        self.acquire()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.release()

    def acquire(self) -> None:
        """Take the lock, creating the folder if need be.

        Raises:
            InvalidInput: Another process holds it, or the folder or its lock file cannot be
                created.
        """
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            allowed = "a folder where files can be created and written"
            raise InvalidInput(self.field, allowed, f"{self.folder}: {exc.strerror}") from None
        for _ in range(_ATTEMPTS):
            fd = self._open()
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                holder = self.holder()
                by = f"process {holder}" if holder else "another process"
                allowed = "a folder no other sortsim run or sweep is using"
                got = f"{self.folder} is in use by {by}"
                raise InvalidInput(self.field, allowed, got) from None
            if self._still_ours(fd):
                self._fd = fd
                break
            os.close(fd)  # the holder removed the file as we took it: take the new one
        else:
            raise InvalidInput(self.field, "a folder whose lock can be taken", str(self.folder))
        with contextlib.suppress(OSError):  # the process id is for the refusal's words only
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())

    def release(self) -> None:
        """Let the lock go and remove its file (nothing when it is not held)."""
        if self._fd is None:
            return
        with contextlib.suppress(OSError):
            self.path.unlink()
        os.close(self._fd)
        self._fd = None

    @property
    def held(self) -> bool:
        """Whether this object holds the lock now."""
        return self._fd is not None

    def holder(self) -> int | None:
        """The process id written in the lock file (None when unknown)."""
        try:
            text = self.path.read_text(encoding="ascii", errors="replace").strip()
        except OSError:
            return None
        return int(text) if text.isdigit() else None

    def _open(self) -> int:
        try:
            return os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        except OSError as exc:
            allowed = "a folder where files can be created and written"
            raise InvalidInput(self.field, allowed, f"{self.path}: {exc.strerror}") from None

    def _still_ours(self, fd: int) -> bool:
        """Whether the locked file is still the one at `path` (not removed by a releaser)."""
        try:
            now, ours = os.stat(self.path), os.fstat(fd)
        except OSError:
            return False
        return (now.st_dev, now.st_ino) == (ours.st_dev, ours.st_ino)
