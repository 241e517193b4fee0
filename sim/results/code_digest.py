"""The code that decides results, named by a digest, and the git commit it stands at.

`code_digest()` names the code an episode ran on: the SHA-256 over every file under
`CODE_ROOTS` (the simulation, the planners, the perception and the MJCF models, with the data
and configuration files they read: `sim/data`, the models' XML and JSON, the learned policy),
each as its path relative to the repository and its content's SHA-256, in sorted path order, cut
to `DIGEST_HEX` hex digits. Left out: docs (`*.md`), licences, Python's caches (`__pycache__`,
`*.pyc`) and hidden files (the project's temporaries); tests, benchmarks, docs, sweep files and
the runs' caches lie outside the roots (a sweep's own settings are in its identity). Any byte
changed in any of these files gives another digest; the same files give the same digest on any
machine, inside git or not. It is computed once per process (the files are read then: a few
tens of milliseconds) and recorded in every episode's row (`code_digest` in episodes.csv), in
a manifest and in the first line of every `sortsim reproduce` block.

`code_commit()` is the git commit of the checkout, and whether the roots hold changes not
committed (files changed or not tracked); None outside a git checkout or without git.
"""

from __future__ import annotations

import functools
import hashlib
import subprocess
from collections import Counter
from collections.abc import Iterable, Mapping
from pathlib import Path

from sim.paths import REPO_ROOT

CODE_ROOTS = ("sim", "planner", "perception", "models")
"""The folders, relative to the repository, whose files decide results."""
DIGEST_HEX = 16
"""Hex digits of a digest (64 bits, as a sweep's identity)."""
DIGEST_COLUMN = "code_digest"
"""The episodes.csv column holding the digest of the code the episode ran on."""
COMMIT_HEX = 12
"""Hex digits of a commit as a block names it."""
_SKIPPED_DIRS = {"__pycache__"}
_SKIPPED_SUFFIXES = {".md", ".pyc", ".pyo"}


def _counted(path: Path) -> bool:
    """Whether a file under a root counts: not hidden, no doc, licence or cache."""
    name = path.name
    if name.startswith(".") or path.suffix.lower() in _SKIPPED_SUFFIXES:
        return False
    return not name.upper().startswith("LICENSE")


def code_files(root: Path = REPO_ROOT) -> list[Path]:
    """The files the digest covers, relative to `root`, in sorted (POSIX) path order."""
    root = Path(root)
    out = []
    for top in CODE_ROOTS:
        base = root / top
        if not base.is_dir():
            continue
        for path in base.rglob("*"):
            parts = path.relative_to(root).parts
            if any(p in _SKIPPED_DIRS or p.startswith(".") for p in parts[:-1]):
                continue
            if path.is_file() and _counted(path):
                out.append(path.relative_to(root))
    return sorted(out, key=lambda p: p.as_posix())


def digest_of(root: Path = REPO_ROOT) -> str:
    """The digest of the code under `root` (see the module docstring), computed now."""
    total = hashlib.sha256()
    for rel in code_files(root):
        content = hashlib.sha256((Path(root) / rel).read_bytes()).hexdigest()
        total.update(f"{rel.as_posix()}\0{content}\n".encode())
    return total.hexdigest()[:DIGEST_HEX]


@functools.cache
def code_digest() -> str:
    """The digest of this process's code (the repository it runs from), computed once."""
    return digest_of(REPO_ROOT)


def git_commit(root: Path = REPO_ROOT) -> dict[str, object] | None:
    """{'commit': sha, 'dirty': bool} of `root`'s checkout, dirty when `CODE_ROOTS` hold
    changes not committed (or files not tracked); None outside git or without git."""
    return git_state(root, CODE_ROOTS, untracked=True)


def git_state(
    root: Path = REPO_ROOT, paths: tuple[str, ...] = (), untracked: bool = False
) -> dict[str, object] | None:
    """{'commit': sha, 'dirty': bool} of `root`'s checkout, dirty when `paths` (every path:
    ()) hold changes not committed (and, `untracked`, files not tracked); None outside git or
    without git. Git runs without optional locks: the index is left as it is (a run writes
    nothing into the checkout, .git included)."""
    if not (Path(root) / ".git").exists():
        return None
    status_cmd = ["git", "--no-optional-locks", "status", "--porcelain"]
    status_cmd += [] if untracked else ["--untracked-files=no"]
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10
        )
        status = subprocess.run(
            [*status_cmd, "--", *paths], cwd=root, capture_output=True, text=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):
        return None
    if commit.returncode != 0 or status.returncode != 0:
        return None
    return {"commit": commit.stdout.strip(), "dirty": bool(status.stdout.strip())}


@functools.cache
def code_commit() -> dict[str, object] | None:
    """`git_commit` of this process's repository, asked once."""
    return git_commit(REPO_ROOT)


def commit_text(state: Mapping[str, object] | None) -> str:
    """'commit 01ca9c2d4e5f', '... with uncommitted changes', or 'no git commit'."""
    if not state:
        return "no git commit"
    text = f"commit {str(state['commit'])[:COMMIT_HEX]}"
    return text + (" with uncommitted changes" if state.get("dirty") else "")


def digests_of(rows: Iterable[Mapping[str, object]]) -> Counter:
    """How many rows carry each digest ('' for a row written before the column existed)."""
    return Counter(str(row.get(DIGEST_COLUMN) or "") for row in rows)


def counts_text(counts: Mapping[str, int]) -> str:
    """'0123456789abcdef (40 episodes), none recorded (3 episodes)', most episodes first."""
    parts = []
    for digest, n in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])):
        name = digest or "none recorded"
        parts.append(f"{name} ({n} episode{'s' if n != 1 else ''})")
    return ", ".join(parts)


def provenance(counts: Mapping[str, int], current: str, commit: str) -> str:
    """What a block ran on: 'commit C, code digest D' when every episode counted ran on this
    code (`current`, at `commit`), else that and '; MIXED CODE: its episodes ran on code
    digests ...'.

    Args:
        counts: Episodes per digest (`digests_of`); empty for a block without episodes.
        current: This process's digest.
        commit: This process's `commit_text`.
    """
    text = f"{commit}, code digest {current}"
    if any(d != current for d in counts):
        text += f"; MIXED CODE: its episodes ran on code digests {counts_text(counts)}"
    return text
