"""The episode's output files, written atomically with fixed number formatting.

`episodes.csv` has one row per episode and `picks.csv` one row per pick attempt (docs/episode.md's
columns, plus a few more at the end). Every write goes to a temporary file in the same folder
and is renamed over the target (`os.replace`), so a killed run leaves either the old file or
the new one, never half a CSV. Floats are printed with a fixed number of decimals per column,
so the same seed and config give byte-identical files; only the wall-clock columns
(`WALL_COLUMNS`) depend on the machine.
"""

from __future__ import annotations

import csv
import io
import os
import tempfile
from collections.abc import Iterable, Mapping
from pathlib import Path

EPISODE_COLUMNS = (
    "seed",
    "planner",
    "speed_factor",
    "belt_speed_mps",
    "n_items",
    "picked",
    "picked_paper",
    "picked_plastic",
    "picked_aluminium",
    "wrong_bin",
    "missed",
    "accuracy",
    "profit_eur",
    "mean_cycle_s",
    "sim_s",
    "wall_s",
    # beyond the contract's minimum (docs/episode.md)
    "variant",
    "perception",
    "entered",
    "attempts",
    "failed_picks",
    "dropped",
    "entered_paper",
    "entered_plastic",
    "entered_aluminium",
    "real_time_factor",
    "mujoco_warnings",
    "thrown_off",
)
PICK_COLUMNS = (
    "t_start_s",
    "t_end_s",
    "item_id",
    "true_class",
    "predicted_class",
    "bin",
    "success",
    "cycle_s",
)
WALL_COLUMNS = ("wall_s", "real_time_factor")

# Decimals per float column; anything not listed is written with str().
_DECIMALS = {
    "speed_factor": 3,
    "belt_speed_mps": 4,
    "accuracy": 4,
    "profit_eur": 4,
    "mean_cycle_s": 4,
    "sim_s": 3,
    "wall_s": 3,
    "real_time_factor": 2,
    "t_start_s": 4,
    "t_end_s": 4,
    "cycle_s": 4,
}


def format_value(column: str, value: object) -> str:
    """The text of one CSV cell: fixed decimals for float columns, str() otherwise."""
    if value is None:
        return ""
    if column in _DECIMALS and not isinstance(value, str):
        return f"{float(value):.{_DECIMALS[column]}f}"
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def to_csv_text(columns: Iterable[str], rows: Iterable[Mapping[str, object]]) -> str:
    """The whole CSV text (header + rows, '\\n' line ends) of `rows` in `columns` order."""
    columns = tuple(columns)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([format_value(c, row.get(c)) for c in columns])
    return buffer.getvalue()


def write_atomic(path: Path, data: str | bytes) -> Path:
    """Write `data` to `path` through a temporary file in the same folder and a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    mode = "wb" if isinstance(data, bytes) else "w"
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes it private; give it a normal file's mode
        with os.fdopen(fd, mode, **({} if mode == "wb" else {"encoding": "utf-8"})) as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def read_rows(path: Path) -> list[dict[str, str]]:
    """Rows of a CSV written here (empty list when the file does not exist)."""
    path = Path(path)
    if not path.exists():
        return []
    with path.open(newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def write_episodes(path: Path, rows: Iterable[Mapping[str, object]]) -> Path:
    """Write `episodes.csv` (one row per episode) atomically."""
    return write_atomic(path, to_csv_text(EPISODE_COLUMNS, rows))


def write_picks(path: Path, rows: Iterable[Mapping[str, object]]) -> Path:
    """Write `picks.csv` (one row per pick attempt) atomically."""
    return write_atomic(path, to_csv_text(PICK_COLUMNS, rows))


def append_episode(path: Path, row: Mapping[str, object]) -> Path:
    """Append one finished episode to `episodes.csv` (the file is rewritten atomically).

    Rows already in the file are kept as text, so an append never reformats earlier rows.
    """
    old = read_rows(path)
    formatted = {c: format_value(c, row.get(c)) for c in EPISODE_COLUMNS}
    return write_atomic(path, to_csv_text(EPISODE_COLUMNS, [*old, formatted]))


def strip_wall_clock(text: str) -> str:
    """CSV text without the wall-clock columns (for determinism checks)."""
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        return ""
    keep = [i for i, name in enumerate(rows[0]) if name not in WALL_COLUMNS]
    return "\n".join(",".join(r[i] for i in keep) for r in rows) + "\n"
