"""The episode's output files, written atomically with fixed number formatting.

`episodes.csv` has one row per episode and `picks.csv` one row per pick attempt (docs/episode.md's
columns, plus a few more at the end). Every write goes to a temporary file in the same folder
and is renamed over the target (`os.replace`), so a killed run leaves either the old file or
the new one, never half a CSV. Floats are printed with a fixed number of decimals per column,
so the same seed and config give byte-identical files; only the wall-clock columns
(`WALL_COLUMNS`) depend on the machine. A value that is undefined (None in a row: the purity of
an empty bin, the recovery of a class no item of which entered) is an empty cell.

Outputs are checked before any work (`check_output_dir`, `check_output_file`): a folder that
cannot be created or written, a file path naming a folder, are refused in one line before the
episode runs, so no result is lost to an unusable output. Permissions alone do not tell (root
passes `os.access` on `/proc` and on a read-only or full file system), so the check creates the
folder if need be, writes, syncs and removes a small probe file in it (`PROBE_BYTES`), and
removes again the folders it created. The temporaries follow `sim.paths.temporary_path`; those
of a killed run are removed at the next start (`sim.paths.remove_stale_temporaries`).

A run folder's files are written as one unit (`write_together`): every file's temporary is
written and synced first, then each is renamed into place in order (the manifest last), so a
write that fails (a full disk) leaves the folder as it was, and a folder whose manifest is new
has every file of its run. What could not be written is kept as JSON in a recoverable place
(`keep_unwritten`: in the user's cache folder, else the system's temporary folder).
"""

from __future__ import annotations

import contextlib
import csv
import datetime
import io
import json
import os
import tempfile
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from perception.codes import THESIS_MATERIALS, Materials
from sim.config.faults import FAULT_KINDS
from sim.errors import InvalidInput, SortsimError
from sim.paths import temporary_path

PROBE_BYTES = 4096
"""Size of the probe file written into an output folder before any work (one page)."""
UNWRITTEN = "unwritten"
"""The folder of the user's cache folder where results that could not be written to their
folder are kept (`keep_unwritten`)."""


class OutputError(SortsimError):
    """An output that could not be written once the work was done (a full disk, a failed
    video): one line saying what is kept where, exit code 1."""


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
    "energy_mech_j",
    "energy_elec_j",
    "energy_price_eur_per_kwh",
    "energy_cost_eur",
    "net_profit_eur",
    "purity_paper",
    "purity_plastic",
    "purity_aluminium",
    "recovery_paper",
    "recovery_plastic",
    "recovery_aluminium",
    "never_detected",
    "never_visible",
    "empty_picks",
    "min_class_confidence",
    "left_unsure",
    "items_per_m",
    "code_digest",
    # money as a plant counts it (sim/results/economics.py)
    "mass_entered_kg",
    "mass_recovered_kg",
    "recovered_items_per_h",
    "recovered_kg_per_h",
    "profit_per_h_eur",
    "robot_cost_per_h_eur",
    "robot_capital_eur",
    "robot_life_years",
    "hours_per_year",
    "robot_maintenance_eur_per_year",
    "left_on_belt",
    "not_arrived",
    # a shift's faults (sim.config.faults): seconds of each kind, the robots' availability
    *(f"downtime_{kind}_s" for kind in FAULT_KINDS),
    "availability",
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
    "travel_m",
    "energy_mech_j",
    "energy_elec_j",
    "robot",
)
WALL_COLUMNS = ("wall_s", "real_time_factor")
PER_MATERIAL = ("picked", "entered", "purity", "recovery")
"""Column groups with one column per material (`picked_<material>` ...)."""


def episode_columns(materials: Materials = THESIS_MATERIALS) -> tuple[str, ...]:
    """`EPISODE_COLUMNS` with the per-material columns of `materials` in place of the thesis's
    (the same tuple for paper, plastic and aluminium)."""
    out: list[str] = []
    for column in EPISODE_COLUMNS:
        group, _, material = column.partition("_")
        if group in PER_MATERIAL and material in THESIS_MATERIALS.names:
            if material == THESIS_MATERIALS.names[0]:
                out.extend(f"{group}_{m}" for m in materials.names)
            continue
        out.append(column)
    return tuple(out)


ROBOT_COLUMNS = ("picked", "picks_per_min", "utilisation", "energy_elec_j")
"""A line's columns per robot k: `robot<k>_picked` ... (`EpisodeMetrics.robot_row`)."""


def line_columns(robots: int) -> tuple[str, ...]:
    """The columns a line of `robots` adds to episodes.csv (`robots` alone for one robot)."""
    if robots <= 1:
        return ("robots",)
    per_robot = tuple(f"robot{k}_{c}" for k in range(robots) for c in ROBOT_COLUMNS)
    return ("robots", "coordination", *per_robot)


def sweep_episode_columns(materials_list) -> tuple[str, ...]:
    """The episode columns of a sweep whose episodes sort `materials_list` (their union, in
    first-seen order)."""
    names: list[str] = []
    for materials in materials_list:
        names += [n for n in materials.names if n not in names]
    if tuple(names) == THESIS_MATERIALS.names:
        return EPISODE_COLUMNS
    return episode_columns(Materials(tuple(names), (0.0,) * len(names)))


# Decimals per float column; anything not listed is written with str().
DECIMALS = {
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
    "travel_m": 4,
    "energy_mech_j": 2,
    "energy_elec_j": 2,
    "energy_price_eur_per_kwh": 4,
    "energy_cost_eur": 6,
    "net_profit_eur": 4,
    "min_class_confidence": 4,
    "items_per_m": 3,
    "mass_entered_kg": 4,
    "mass_recovered_kg": 4,
    "recovered_items_per_h": 2,
    "recovered_kg_per_h": 3,
    "profit_per_h_eur": 4,
    "robot_cost_per_h_eur": 4,
    "robot_capital_eur": 2,
    "robot_life_years": 3,
    "hours_per_year": 1,
    "robot_maintenance_eur_per_year": 2,
    **{f"downtime_{kind}_s": 3 for kind in FAULT_KINDS},
    "availability": 4,
}
_DECIMAL_GROUPS = {"purity": 4, "recovery": 4}
_DECIMAL_SUFFIXES = {"picks_per_min": 3, "utilisation": 4, "energy_elec_j": 2}
"""Decimals of a line's per-robot columns (`robot<k>_<suffix>`)."""
"""Decimals of the per-material float columns (`purity_<material>`, ...)."""


def format_value(column: str, value: Any) -> str:
    """The text of one CSV cell: fixed decimals for float columns, str() otherwise."""
    if value is None:
        return ""
    decimals = DECIMALS.get(column) or _DECIMAL_GROUPS.get(column.partition("_")[0])
    if decimals is None and column.startswith("robot"):
        decimals = _DECIMAL_SUFFIXES.get(column.partition("_")[2])
    if decimals is not None and not isinstance(value, str):
        return f"{float(value):.{decimals}f}"
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
    data = data if isinstance(data, bytes) else data.encode("utf-8")
    tmp = temporary_path(path)
    try:
        _write_synced(tmp, data)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def write_together(folder: Path | str, files: Mapping[str, str | bytes | Path]) -> list[Path]:
    """Write `files` into `folder` as one unit: every temporary written and synced first, then
    each renamed into place in the order given (put the manifest last), the folder synced.

    A failure while writing (a full disk) removes every temporary and leaves the folder as it
    was; renames within one folder need no space, so once the temporaries are written the
    files land together.

    Args:
        folder: The folder (created if need be).
        files: {file name: its whole content, or a temporary in `folder` already written and
            synced (`PickStream.finish`)}, in the order they are to land.

    Returns:
        The paths written, in that order.

    Raises:
        OSError: A temporary could not be written (none of the files was replaced).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    staged: list[tuple[Path, Path]] = []
    try:
        for name, data in files.items():
            path = folder / name
            if isinstance(data, Path):  # written and synced already (`PickStream.finish`)
                staged.append((data, path))
                continue
            tmp = temporary_path(path)
            staged.append((tmp, path))
            _write_synced(tmp, data if isinstance(data, bytes) else data.encode("utf-8"))
        for tmp, path in staged:
            os.replace(tmp, path)
    except BaseException:
        for tmp, _ in staged:
            if tmp not in files.values():  # a caller's staged file is the caller's to remove
                tmp.unlink(missing_ok=True)
        raise
    _sync_folder(folder)
    return [path for _, path in staged]


def _write_synced(path: Path, data: bytes) -> None:
    """Create `path` (it must not exist) with `data`, synced to the disk."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # umask applies
    with os.fdopen(fd, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())


def _sync_folder(folder: Path) -> None:
    """Sync a folder's entries (the renames) where the platform allows it."""
    with contextlib.suppress(OSError, AttributeError):
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def keep_unwritten(folder: Path | str, files: Mapping[str, str], reason: str) -> Path | None:
    """Keep results that could not be written to `folder` as one JSON file elsewhere.

    The file holds each output's whole text under `files` (`{"episodes.csv": "...", ...}`), the
    folder they were meant for and why they are not there; writing each text to its name
    restores the folder as the command would have left it. Tried in `unwritten` of the user's
    cache folder (`sim.user_cache`), then in the system's temporary folder.

    Args:
        folder: Where the files were to go.
        files: {file name: its whole text}.
        reason: Why they could not be written, in words.

    Returns:
        The JSON file, or None when neither place could take it.
    """
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%SZ")
    record = {"folder": str(Path(os.path.abspath(folder))), "reason": reason, "files": dict(files)}
    text = json.dumps(record, indent=1) + "\n"
    for place in (_unwritten_dir(), Path(tempfile.gettempdir()) / "sortsim-unwritten"):
        if place is None:
            continue
        path = place / f"{stamp}-{os.getpid()}.json"
        try:
            return write_atomic(path, text)
        except OSError:
            continue
    return None


def _unwritten_dir() -> Path | None:
    """`unwritten` in the user's cache folder; None when that folder cannot be used."""
    from sim.user_cache import cache_dir

    try:
        return cache_dir() / UNWRITTEN
    except InvalidInput:
        return None


def restore_unwritten(record: Path | str, folder: Path | str | None = None) -> list[Path]:
    """Write the files a `keep_unwritten` record holds into their folder (or `folder`).

    Args:
        record: The JSON file `keep_unwritten` wrote.
        folder: Where to write them; the folder they were meant for when None.

    Returns:
        The files written.
    """
    data = json.loads(Path(record).read_text(encoding="utf-8"))
    return write_together(Path(folder or data["folder"]), data["files"])


def _nearest_existing(path: Path) -> Path:
    """`path` or its closest ancestor that exists."""
    path = Path(os.path.abspath(path))
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def check_output_dir(path: Path | str, field: str) -> Path:
    """Refuse an output folder that cannot be created or written, without creating it.

    Args:
        path: The folder the command will write into (created later, when it runs).
        field: The option or key that named it, for the refusal.

    Raises:
        InvalidInput: `path` is an existing file, lies under a file, or the folder (or the
            closest existing ancestor it would be created in) is not writable.
    """
    path = Path(path)
    text = str(path)
    if not text.strip() or "\0" in text:
        raise InvalidInput(field, "a folder path", text)
    if path.exists() and not path.is_dir():
        raise InvalidInput(field, "a folder (this path is an existing file)", text)
    _check_folder(path, field, "a folder path", text)
    return path


def _check_folder(folder: Path, field: str, kind: str, text: str) -> None:
    """Refuse `folder` (existing or to be created) when it could not be written; the refusal
    describes the path given (`kind`, `text`)."""
    existing = _nearest_existing(folder)
    if not existing.is_dir():
        raise InvalidInput(field, f"{kind} ({existing} is a file, not a folder)", text)
    if not os.access(existing, os.W_OK | os.X_OK):
        if existing == Path(os.path.abspath(folder)) and kind == "a folder path":
            raise InvalidInput(field, f"a writable folder ({existing} is not writable)", text)
        raise InvalidInput(field, f"{kind} in a writable folder ({existing} is not)", text)
    failure = probe_folder(folder)
    if failure is not None:
        allowed = "a folder where files can be created and written"
        allowed = allowed if kind == "a folder path" else f"{kind} in {allowed}"
        raise InvalidInput(field, allowed, f"{text}: {failure}")


def probe_folder(folder: Path | str) -> str | None:
    """Create `folder` if need be, write, sync and remove a probe file in it, and remove the
    folders created for it again.

    Args:
        folder: The output folder to try.

    Returns:
        None when it worked, else why not in words (the OS's reason, e.g. "No space left on
        device", "Read-only file system").
    """
    folder = Path(os.path.abspath(folder))
    created = []
    probe = temporary_path(folder / "sortsim-probe")
    try:
        missing = folder
        while not missing.exists() and missing != missing.parent:
            created.append(missing)
            missing = missing.parent
        folder.mkdir(parents=True, exist_ok=True)
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        try:
            os.write(fd, b"\0" * PROBE_BYTES)
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError as exc:
        return exc.strerror or type(exc).__name__
    finally:
        with contextlib.suppress(OSError):
            probe.unlink(missing_ok=True)
        for path in created:  # deepest first; only folders this probe made, if still empty
            with contextlib.suppress(OSError):
                path.rmdir()
    return None


def check_output_file(
    path: Path | str, field: str, suffixes: tuple[str, ...] = (), kind: str = "a file"
) -> Path:
    """Refuse an output file that could not be written, without writing anything.

    Args:
        path: The file the command will write (through a temporary and a rename).
        field: The option or key that named it, for the refusal.
        suffixes: Allowed suffixes (lower case, e.g. (".mp4",)); any when empty.
        kind: What the file is, with its article, for the refusal ("an MP4 file").

    Raises:
        InvalidInput: `path` is a folder (or ends with a separator) or a special file, has
            another suffix, or its folder cannot be created or written.
    """
    text = str(path)
    path = Path(path)
    if not path.name or text.endswith(("/", os.sep)) or "\0" in text:
        raise InvalidInput(field, f"{kind} path, not a folder", text)
    if path.is_dir():
        raise InvalidInput(field, f"{kind} path (this path is an existing folder)", text)
    if path.exists() and not path.is_file():
        raise InvalidInput(field, f"{kind} path (this path is a special file)", text)
    if suffixes and path.suffix.lower() not in suffixes:
        raise InvalidInput(field, f"{kind} path ending in {' or '.join(suffixes)}", text)
    _check_folder(path.parent, field, f"{kind} path", text)
    return path


def read_rows(path: Path) -> list[dict[str, str]]:
    """Rows of a CSV written here (empty list when the file does not exist).

    Raises:
        InvalidInput: the file is unreadable, not UTF-8 or not a CSV with a header.
    """
    path = Path(path)
    if not path.exists():
        return []
    try:
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        reason = " ".join(str(exc).split())[:120]
        raise InvalidInput(path.name, "a readable UTF-8 CSV file", reason, str(path)) from None
    if rows and any(None in r or None in r.values() for r in rows):
        raise InvalidInput(path.name, "a CSV with as many cells as header names", None, str(path))
    return rows


def write_episodes(
    path: Path, rows: Iterable[Mapping[str, object]], columns: tuple[str, ...] = EPISODE_COLUMNS
) -> Path:
    """Write `episodes.csv` (one row per episode) atomically, in `columns` order (a sweep's
    adds its variants' settings at the end)."""
    return write_atomic(path, to_csv_text(columns, rows))


def write_picks(path: Path, rows: Iterable[Mapping[str, object]]) -> Path:
    """Write `picks.csv` (one row per pick attempt) atomically."""
    return write_atomic(path, to_csv_text(PICK_COLUMNS, rows))


INTERRUPTED_PICKS = "picks.interrupted.csv"
"""Where a run stopped by Ctrl-C (or SIGTERM) leaves the picks it had finished."""


class PickStream:
    """picks.csv written row by row while the episode runs (`sim.results.pick_log` hands the
    rows over in order), into a hidden temporary beside it (`sim.paths.temporary_path`), so a
    shift's rows are on the disk rather than in memory and a stopped run still has them.

    Each row is written whole with `os.write` (no buffer to lose) and only whole rows count
    (`size`): a stop in the middle of a row leaves that row out. The file lands by a rename:
    with the run's other files (`write_together` takes `staged`), or alone (`land`). When the
    disk fills, the rows written so far are read back and the stream goes on in memory
    (`text` has them all), so the run's results can still be kept elsewhere. A stream that did
    not land removes its temporary when it closes.

    Args:
        path: The picks.csv it stands for.
        columns: Its columns.
    """

    def __init__(self, path: Path | str, columns: tuple[str, ...] = PICK_COLUMNS):
        self.path, self.columns = Path(path), tuple(columns)
        self.staged = temporary_path(self.path)
        self.rows = 0
        self.size = 0  # bytes of whole rows (and the header) on the disk
        self._fd: int | None = None
        self._memory: list[str] | None = None

    def __enter__(self) -> PickStream:
        self._fd = os.open(self.staged, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        self._write(to_csv_text(self.columns, ()))
        return self

    def __exit__(self, *exc) -> None:
        self._close()
        self.staged.unlink(missing_ok=True)

    def write_row(self, row: Mapping[str, object]) -> None:
        """Append one row (`format_value` of each column)."""
        self._write(to_csv_text(self.columns, [row]).partition("\n")[2])
        self.rows += 1

    def _write(self, text: str) -> None:
        if self._memory is not None:
            self._memory.append(text)
            return
        data = text.encode("utf-8")
        try:
            written = 0
            while written < len(data):
                written += os.write(self._fd, data[written:])  # type: ignore[arg-type]
        except OSError:
            self._memory = [self._read_back(), text]
            return
        self.size += len(data)

    def _read_back(self) -> str:
        """The disk is full: the whole rows written so far, read back (the rest goes on in
        memory), the temporary removed."""
        self._close()
        with self.staged.open("rb") as f:
            text = f.read(self.size).decode("utf-8")
        self.staged.unlink(missing_ok=True)
        return text

    def _close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    @property
    def on_disk(self) -> bool:
        """Whether the rows are in the temporary (False: the disk filled, they are in memory)."""
        return self._memory is None

    def text(self) -> str:
        """The whole CSV text so far (read back from the disk, or from memory)."""
        if self._memory is not None:
            return "".join(self._memory)
        with self.staged.open("rb") as f:
            return f.read(self.size).decode("utf-8")

    def finish(self) -> Path | str:
        """Close the stream: its temporary, synced and cut to its whole rows, for
        `write_together`; or its text when the disk filled."""
        if self._memory is not None:
            return self.text()
        if self._fd is not None:
            os.ftruncate(self._fd, self.size)
            os.fsync(self._fd)
        self._close()
        return self.staged

    def land(self, path: Path | str | None = None) -> Path:
        """Rename the rows written so far into `path` (picks.csv when None) on their own."""
        target = self.path if path is None else Path(path)
        staged = self.finish()
        if isinstance(staged, str):
            return write_atomic(target, staged)
        os.replace(staged, target)
        _sync_folder(target.parent)
        return target


SWEEP_PICK_COLUMNS = ("variant", "planner", "speed_factor", "n_items", "seed", *PICK_COLUMNS)
"""A sweep's picks.csv: each pick with the key columns of its episode."""


def write_sweep_picks(
    path: Path,
    rows: Iterable[Mapping[str, object]],
    columns: tuple[str, ...] = SWEEP_PICK_COLUMNS,
) -> Path:
    """Write a sweep's `picks.csv` atomically, in `columns` order."""
    return write_atomic(path, to_csv_text(columns, rows))


def append_sweep_picks(
    path: Path,
    rows: Iterable[Mapping[str, object]],
    columns: tuple[str, ...] = SWEEP_PICK_COLUMNS,
) -> Path:
    """Append one episode's picks to a sweep's `picks.csv` (rewritten atomically; the rows
    already there are kept as text)."""
    old = read_rows(path)
    new = [{c: format_value(c, r.get(c)) for c in columns} for r in rows]
    return write_atomic(path, to_csv_text(columns, [*old, *new]))


def append_episode(
    path: Path, row: Mapping[str, object], columns: tuple[str, ...] = EPISODE_COLUMNS
) -> Path:
    """Append one finished episode to `episodes.csv` (the file is rewritten atomically).

    Rows already in the file are kept as text, so an append never reformats earlier rows.
    """
    old = read_rows(path)
    formatted = {c: format_value(c, row.get(c)) for c in columns}
    return write_atomic(path, to_csv_text(columns, [*old, formatted]))


def strip_wall_clock(text: str) -> str:
    """CSV text without the wall-clock columns (for determinism checks)."""
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        return ""
    keep = [i for i, name in enumerate(rows[0]) if name not in WALL_COLUMNS]
    return "\n".join(",".join(r[i] for i in keep) for r in rows) + "\n"
