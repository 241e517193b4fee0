"""Where the project's files are: one place, so no module spells a path twice.

What the project computes once and keeps between runs is not here but in the user's cache
folder (`sim.user_cache`), never inside the install.

Also the one naming scheme of the project's temporary files. Every output is written to a
hidden temporary file beside its target and renamed over it; the temporary's name carries the
writing process's id, `.<target name>.<pid>.<token>.tmp[<suffix>]`, so a later run can tell the
leftovers of a killed process (its id no longer running) from a file another process is
writing right now, and remove them (`remove_stale_temporaries`).
"""

from __future__ import annotations

import os
import re
import secrets
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
MODELS_DIR = REPO_ROOT / "models"
ROBOT_XML = MODELS_DIR / "abb_irb360" / "irb360.xml"
SCENE_XML = MODELS_DIR / "cell" / "scene.xml"
DATA_DIR = REPO_ROOT / "sim" / "data"
EXPERIMENTS_DIR = REPO_ROOT / "experiments"
CAMERA_CALIBRATION_JSON = MODELS_DIR / "cell" / "belt_camera_calibration.json"

_TOKEN_HEX = 8
_TEMPORARIES = (
    re.compile(r"^\..+\.(?P<pid>\d+)\.[0-9a-f]{8}\.tmp(?:\.[A-Za-z0-9]+)?$"),
    re.compile(r"^\..+\.(?P<pid>\d+)\.tmp\.mp4$"),  # the videos' earlier name
    re.compile(r"^\.stripe_hmms-[0-9a-f]+\.(?P<pid>\d+)\.npz$"),  # the HMM cache's earlier name
)
"""Names of the project's temporaries, each with the id of the process writing it."""


def temporary_path(path: Path | str, suffix: str = "") -> Path:
    """A fresh temporary path beside `path` in the project's scheme (see the module docstring).

    Args:
        path: The target the temporary will be renamed to.
        suffix: Kept at the end (e.g. ".mp4", for writers that choose the format by suffix).
    """
    path = Path(path)
    token = secrets.token_hex(_TOKEN_HEX // 2)
    return path.with_name(f".{path.name}.{os.getpid()}.{token}.tmp{suffix}")


def process_alive(pid: int) -> bool:
    """Whether a process `pid` exists on this machine (this process counts as alive)."""
    if pid == os.getpid():
        return True
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    except OverflowError:
        return False
    return True


def stale_temporaries(folder: Path | str) -> list[Path]:
    """Temporaries in `folder` left by processes that are no longer running (killed runs)."""
    folder = Path(folder)
    try:
        names = sorted(os.listdir(folder))
    except OSError:
        return []
    stale = []
    for name in names:
        match = next((m for r in _TEMPORARIES if (m := r.match(name))), None)
        if match and not process_alive(int(match["pid"])):
            path = folder / name
            if path.is_file() and not path.is_symlink():
                stale.append(path)
    return stale


def remove_stale_temporaries(*folders: Path | str) -> list[Path]:
    """Delete the leftovers of killed runs in `folders`; returns what was removed."""
    removed = []
    for folder in folders:
        for path in stale_temporaries(folder):
            try:
                path.unlink()
            except OSError:
                continue
            removed.append(path)
    return removed
