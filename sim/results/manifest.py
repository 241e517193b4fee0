"""`manifest.json`: what produced a run or sweep folder, for any tool that reads it later.

In the manner of a trial folder of an experiment tracker: beside `episodes.csv` (and
`picks.csv`), one JSON object with the fully resolved configuration (every key, defaults
included), the seeds, the package version, the git commit of the source tree when it is a
checkout (and whether it had uncommitted changes), the digest of the code that decides results
(`sim.results.code_digest`), the MuJoCo, Python and NumPy versions, the
machine (CPU model, cores, OS) and the command line. A sweep's is written atomically before its
first episode runs; a run's lands with its CSVs, last of the three (`text`, written by
`sim.results.outputs.write_together`), and names each CSV's SHA-256 under `files`
(`file_digests`), so a folder whose CSVs match its manifest holds one run's files. A folder with
results always says how they were made; the CSVs stay byte-identical for a seed and config (the
manifest's time stamp and machine are not in them).
"""

from __future__ import annotations

import datetime
import hashlib
import json
import os
import platform
import sys
from collections.abc import Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

from sim.results.code_digest import code_digest, git_state
from sim.results.outputs import write_atomic

MANIFEST_FILE = "manifest.json"
FORMAT = 1
"""Version of the manifest's layout (raised when a key changes meaning)."""


def package_version() -> str:
    """The installed sortsim's version ('unknown' when it is not installed)."""
    try:
        return metadata.version("sortsim")
    except metadata.PackageNotFoundError:
        return "unknown"


def cpu_model() -> str:
    """The CPU's model name (from /proc/cpuinfo on Linux, else the platform's answer)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def build(kind: str, config: Any, seeds: list[int], argv: list[str] | None = None) -> dict:
    """The manifest of a `kind` ('run' or 'sweep') folder.

    Args:
        kind: 'run' or 'sweep'.
        config: The resolved configuration, JSON-ready (dicts, lists, numbers, strings).
        seeds: The seeds the folder's episodes use.
        argv: The command line (sys.argv when None).
    """
    import mujoco
    import numpy

    return {
        "format": FORMAT,
        "kind": kind,
        "created_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "sortsim_version": package_version(),
        "git": git_state(),
        "code_digest": code_digest(),
        "mujoco_version": mujoco.__version__,
        "numpy_version": numpy.__version__,
        "python_version": platform.python_version(),
        "machine": {
            "cpu": cpu_model(),
            "cores": os.cpu_count(),
            "os": platform.platform(),
        },
        "command": list(sys.argv if argv is None else argv),
        "seeds": sorted({int(s) for s in seeds}),
        "config": config,
    }


def file_digests(files: Mapping[str, str | bytes]) -> dict[str, str]:
    """The SHA-256 (hex) of each file's content, for a manifest's `files`.

    Args:
        files: {file name: its whole content}.

    Returns:
        {file name: hex digest}.
    """
    out = {}
    for name, data in files.items():
        out[name] = hashlib.sha256(data if isinstance(data, bytes) else data.encode()).hexdigest()
    return out


def text(manifest: dict) -> str:
    """The manifest's JSON text as `write` writes it.

    Args:
        manifest: The manifest (`build`).

    Returns:
        The JSON, indented, with a final line end.
    """
    return json.dumps(manifest, indent=2, sort_keys=False) + "\n"


def write(out_dir: Path, manifest: dict) -> Path:
    """Write `manifest.json` in `out_dir` atomically."""
    return write_atomic(Path(out_dir) / MANIFEST_FILE, text(manifest))
