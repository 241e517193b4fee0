"""Running a sweep's episodes: resume, local process pool, or a Ray cluster.

One row is appended to `<out>/episodes.csv` per finished episode (rewritten atomically), so a
killed sweep keeps every finished episode; running it again skips them (resume). When every
episode is done the file is rewritten once more in the grid's order, so the same sweep gives
the same bytes (wall-clock columns aside) whatever the number of workers. Both CSVs end with
one column per setting the sweep's variants change (`variant.<key>`,
`SweepConfig.variant_columns`); a folder written before those columns existed gets them filled
in, from each row's episode, when the sweep resumes.

`<out>/timeline.csv` holds every episode's timeline (`sim.results.timeline`), each row led by
its episode's key columns (`timeline_columns`), appended as the episode finishes, before its
row in episodes.csv: an episode whose row is there has its timeline rows. A start drops the
timeline rows (and picks) of an episode killed before its row was written, so a resumed sweep
reruns it without counting them twice. Only the sweep's own process writes the three files,
each write a whole rewrite through a temporary: workers hand their rows over, never write.

The output folder is checked before the first episode (`check_out_dir`): it must be creatable
and writable, and an `episodes.csv` already there must be this sweep's. The sweep's identity
(`SweepConfig.identity`, a hash of its resolved grid, seeds aside) is recorded in `sweep.json`
beside it; an `episodes.csv` of another sweep is refused, never merged. (A folder written before
`sweep.json` existed is accepted when every row belongs to this grid.) Every row carries the
digest of the code its episode ran on (`code_digest`, `sim.results.code_digest`); a folder
holding a row of another digest, or of none, is refused as well (`check_code`), unless the
caller mixes code knowingly (`mix_code`, `--mix-code`). Leftover temporaries of a
killed sweep are removed when it starts again. A refusal raised in a worker process reaches the
parent intact (refusals pickle) and stops the sweep with its one line. A run's folder (its
manifest.json of kind "run") is refused too: its row would pass for one of the sweep's.

A row that cannot be written (the folder's disk is full) stops the sweep with one line
(`OutputError`, exit code 1); the rows written before stay as they were (every write is a
rewrite through a temporary), and running the same command again resumes.

Local workers (`--workers N`) are born ignoring SIGINT, so a Ctrl-C reaches the parent alone
(which ends the pool: no worker prints its own interruption; one sent while they are spawned
waits, blocked, for the parent), and they end with their
parent, however it ends: Linux's parent-death signal (`prctl(PR_SET_PDEATHSIG)`) kills a worker
the moment the sweep's process dies, and a watchdog thread (`PARENT_POLL_S`) catches what that
cannot (another platform, a worker whose parent died before it was set).
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from sim.checks import check, is_integer
from sim.errors import InvalidInput, RefusedInput
from sim.experiments.sweep_config import EpisodeSpec, SweepConfig, episode_key, variant_values
from sim.paths import remove_stale_temporaries
from sim.results import code_digest, manifest, outputs, timeline

IDENTITY_FILE = "sweep.json"
"""The file beside `episodes.csv` that names the sweep its rows belong to."""

RowCallback = Callable[[EpisodeSpec, dict, list[dict], list[dict]], None]
"""Called in the sweep's process with an episode's row, picks and timeline rows."""
PICKS_FILE = "picks.csv"
"""Every pick attempt of the sweep's episodes, each with its episode's key columns."""
PICK_KEY_COLUMNS = ("variant", "planner", "speed_factor", "n_items", "seed")
"""The columns that name a pick's episode in the sweep's picks.csv."""
TIMELINE_FILE = timeline.TIMELINE_FILE
"""Every episode's timeline, each row with its episode's key columns ahead."""
PARENT_POLL_S = 0.5
"""How often a local worker's watchdog checks that the sweep's process is still there [s]."""
_PR_SET_PDEATHSIG = 1


def row_key(row: dict) -> str:
    """The episode key of an episodes.csv row."""
    return episode_key(
        row.get("variant") or "base",
        row["planner"],
        float(row["speed_factor"]),
        int(row["n_items"]),
        int(row["seed"]),
    )


def _row_keys(csv_path: Path) -> list[str]:
    """The episode keys of the rows of `csv_path`; refused if a row is not a sweep's."""
    keys = []
    for number, row in enumerate(outputs.read_rows(csv_path), start=2):
        try:
            keys.append(row_key(row))
        except (KeyError, TypeError, ValueError):
            allowed = "rows written by sortsim sweep"
            raise InvalidInput(csv_path.name, allowed, f"line {number}", str(csv_path)) from None
    return keys


def pending(sweep: SweepConfig, csv_path: Path) -> list[EpisodeSpec]:
    """Episodes of `sweep` without a row in `csv_path` yet, in grid order."""
    done = set(_row_keys(Path(csv_path)))
    return [spec for spec in sweep.episodes if spec.key not in done]


def _recorded_identity(out: Path) -> str | None:
    """The identity in `out`/sweep.json, None without one; refused when unreadable."""
    path = out / IDENTITY_FILE
    if not path.exists():
        return None
    try:
        identity = json.loads(path.read_bytes().decode("utf-8"))["identity"]
    except (OSError, ValueError, KeyError, TypeError):
        allowed = "a sweep.json written by sortsim sweep (delete the folder's files to start anew)"
        raise InvalidInput(IDENTITY_FILE, allowed, None, str(out)) from None
    return str(identity)


def _point(key: str) -> str:
    """An episode key without its seed."""
    return key.rpartition("|")[0]


def check_out_dir(sweep: SweepConfig, out_dir: Path, mix_code: bool = False) -> None:
    """Refuse, before any work, an output folder this sweep cannot use.

    Args:
        sweep: The sweep.
        out_dir: Its folder.
        mix_code: Accept rows that ran on other code (`check_code`).

    Raises:
        InvalidInput: the folder cannot be created or written, `episodes.csv` or `sweep.json`
            there is a folder or unreadable, the rows there are another sweep's, or (without
            `mix_code`) they ran on other code.
    """
    out = Path(out_dir)
    outputs.check_output_dir(out, "--out")
    for name in ("episodes.csv", IDENTITY_FILE):
        outputs.check_output_file(out / name, "--out")
    if _manifest_kind(out) == "run":
        allowed = "a sweep's folder, not a run's (its manifest.json is a run's)"
        raise InvalidInput("--out", allowed, str(out))
    keys = _row_keys(out / "episodes.csv")
    if not keys:
        return
    _check_same_sweep(sweep, out, keys)
    if not mix_code:
        check_code(out)


def check_code(out: Path) -> None:
    """Refuse a sweep folder whose episodes ran on other code than this process's: every row
    of its episodes.csv must carry this code's digest (`sim.results.code_digest`), so that a
    resumed sweep, and a block made from it, is of one code. `--mix-code` tops it up anyway.

    Raises:
        InvalidInput: One line naming the folder, this code's digest and the rows' digests.
    """
    ours = code_digest.code_digest()
    counts = code_digest.digests_of(outputs.read_rows(out / "episodes.csv"))
    others = {d: n for d, n in counts.items() if d != ours}
    if others:
        allowed = (
            f"a folder whose episodes ran on this code (code digest {ours}), "
            "or --mix-code to add to it knowingly"
        )
        got = f"{out}: episodes of code digest {code_digest.counts_text(others)}"
        raise InvalidInput("--out", allowed, got)


def _check_same_sweep(sweep: SweepConfig, out: Path, keys: list[str]) -> None:
    """Refuse a folder whose rows (`keys`) are another sweep's."""
    recorded = _recorded_identity(out)
    ours = {_point(spec.key) for spec in sweep.episodes}
    if recorded is None:  # written before sweep.json existed: every row must be of this grid
        foreign = any(_point(k) not in ours for k in keys)
    else:
        foreign = recorded != sweep.identity
    if foreign:
        allowed = (
            "a new folder, or one holding this sweep's own results to resume "
            "(the episodes.csv there is of another sweep)"
        )
        raise InvalidInput("--out", allowed, str(out))


def _manifest_kind(out: Path) -> str | None:
    """The `kind` of the manifest.json in `out` ("run", "sweep"; None without a readable one)."""
    try:
        data = json.loads((out / "manifest.json").read_bytes().decode("utf-8"))
    except (OSError, ValueError):
        return None
    return data.get("kind") if isinstance(data, dict) else None


def _start(sweep: SweepConfig, out: Path) -> None:
    """Remove a killed run's temporaries and record the sweep's identity beside its rows."""
    out.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(out)
    if _recorded_identity(out) != sweep.identity:
        text = {"sweep": sweep.name, "identity": sweep.identity, "config": sweep.path}
        outputs.write_atomic(out / IDENTITY_FILE, json.dumps(text, indent=2) + "\n")
    episodes_path = out / "episodes.csv"
    rows = outputs.read_rows(episodes_path)
    if _with_variant_values(sweep, rows):  # rows of before the variants' columns: filled in
        outputs.write_episodes(episodes_path, rows, episode_columns(sweep))
    done = set(_row_keys(out / "episodes.csv"))
    picks_path = out / PICKS_FILE
    if picks_path.exists():  # drop the picks of an episode killed before its row was written
        rows = outputs.read_rows(picks_path)
        kept = [r for r in rows if row_key(r) in done]
        filled = _with_variant_values(sweep, kept)
        if len(kept) != len(rows) or filled:
            outputs.write_sweep_picks(picks_path, kept, pick_columns(sweep))
    steps_path = out / TIMELINE_FILE
    steps = outputs.read_rows(steps_path)
    kept = [r for r in steps if row_key(r) in done]  # as for the picks
    if len(kept) != len(steps):
        timeline.write_rows(steps_path, timeline_columns(sweep), kept)


def seeds(sweep: SweepConfig) -> list[int]:
    """The seeds of a sweep's episodes, in its order."""
    return [spec.config.seed for spec in sweep.episodes]


def manifest_config(sweep: SweepConfig) -> dict:
    """A sweep's resolved configuration for its manifest: name, table, identity and each grid
    point's full episode config (seed aside), in the sweep's order."""
    points, seen = [], set()
    for spec in sweep.episodes:
        resolved = spec.config.to_dict()
        resolved.pop("seed")
        key = (spec.variant, repr(sorted(resolved.items())))
        if key not in seen:
            seen.add(key)
            points.append({"variant": spec.variant, "config": resolved})
    return {
        "name": sweep.name,
        "table": sweep.table,
        "identity": sweep.identity,
        "file": sweep.path,
        "grid": points,
    }


def write_manifest(sweep: SweepConfig, out: Path) -> Path:
    """The sweep's manifest.json in `out` (created), once the folder is checked."""
    Path(out).mkdir(parents=True, exist_ok=True)
    return manifest.write(out, manifest.build("sweep", manifest_config(sweep), seeds(sweep)))


def episode_columns(sweep: SweepConfig) -> tuple[str, ...]:
    """The columns of a sweep's episodes.csv: a run's (with the columns of every material its
    episodes sort), then its variants' settings."""
    materials = (spec.config.materials for spec in sweep.episodes)
    robots = max((spec.config.robot_count for spec in sweep.episodes), default=1)
    line = outputs.line_columns(robots)
    return outputs.sweep_episode_columns(materials) + line + sweep.variant_columns


def pick_columns(sweep: SweepConfig) -> tuple[str, ...]:
    """The columns of a sweep's picks.csv: the episode's key, a run's, the variants' settings."""
    return outputs.SWEEP_PICK_COLUMNS + sweep.variant_columns


def timeline_columns(sweep: SweepConfig) -> tuple[str, ...]:
    """The columns of a sweep's timeline.csv: the episode's key and its variants' settings,
    then a timeline's (a state column per robot of the sweep's largest line)."""
    robots = max((spec.config.robot_count for spec in sweep.episodes), default=1)
    key = PICK_KEY_COLUMNS + sweep.variant_columns
    return key + timeline.timeline_columns(robots)


def _with_variant_values(sweep: SweepConfig, rows: list[dict]) -> bool:
    """Give rows written without a variant column (a folder of before the column existed)
    the values of their episode, in place; True if any row got one."""
    if not sweep.variant_keys:
        return False
    specs = {spec.key: spec for spec in sweep.episodes}
    filled = False
    for row in rows:
        spec = specs.get(row_key(row))
        missing = [c for c in sweep.variant_columns if c not in row]
        if spec is not None and missing:
            values = variant_values(spec, sweep.variant_keys)
            row.update({c: outputs.format_value(c, values[c]) for c in missing})
            filled = True
    return filled


def run_spec(spec: EpisodeSpec) -> tuple[dict, list[dict], list[dict]]:
    """Run one episode of a sweep in this process (the compiled model is cached per process);
    returns its episodes.csv row, picks.csv rows and timeline rows."""
    from sim.episode.runner import run_episode

    result = run_episode(spec.config, variant=spec.variant)
    return result.episode_row, result.pick_rows, result.timeline_rows


def dispatch_order(specs: list[EpisodeSpec]) -> list[EpisodeSpec]:
    """The order workers take `specs` in: the longest flows first, the densest and the
    largest lines among equals (longest-processing-time-first scheduling: the last episodes
    to start are short, so no worker idles long while another finishes a 191 s flow). The
    output files are rewritten in the grid's order at the end, so this order never shows."""

    def cost(spec: EpisodeSpec) -> tuple[float, int, int]:
        c = spec.config
        return (c.duration_s, c.items, c.robot_count)

    return sorted(specs, key=cost, reverse=True)


def _local(specs: list[EpisodeSpec], workers: int, on_row: RowCallback) -> None:
    if workers <= 1:
        for spec in specs:
            on_row(spec, *run_spec(spec))
        return
    specs = dispatch_order(specs)
    # spawn: a fresh interpreter per worker, no inherited rendering contexts or threads.
    context = multiprocessing.get_context("spawn")
    with contextlib.ExitStack() as stack:
        with _sigint_blocked():  # the workers are born with it blocked, then ignore it
            pool = stack.enter_context(
                context.Pool(
                    processes=min(workers, len(specs)),
                    maxtasksperchild=None,
                    initializer=_worker_start,
                    initargs=(os.getpid(),),
                )
            )
        by_key = {spec.key: spec for spec in specs}
        for key, result in pool.imap_unordered(_keyed, specs, chunksize=1):
            on_row(by_key[key], *result)


@contextlib.contextmanager
def _sigint_blocked():
    """SIGINT blocked and ignored meanwhile, in the main thread: processes spawned now are born
    ignoring it (a disposition to ignore survives `exec`, and Python keeps it), so a Ctrl-C
    cannot reach a worker while it starts; one that comes meanwhile stays pending (Linux never
    drops a blocked signal) and reaches this process once its handler is back."""
    main = threading.current_thread() is threading.main_thread()
    if not (main and hasattr(signal, "pthread_sigmask")):
        yield
        return
    with contextlib.suppress(ImportError, AttributeError, OSError):
        from multiprocessing import resource_tracker

        resource_tracker.ensure_running()  # it unblocks SIGINT when it starts: start it first
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    handler = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, handler)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _worker_start(parent: int) -> None:
    """A local worker's start: Ctrl-C is the parent's to handle; the worker ends when the
    sweep's process `parent` is gone (parent-death signal on Linux, else the watchdog)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # the parent died before the signal was set
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


def _watch_parent(parent: int) -> None:
    """End this worker at once when its parent process is gone (it was re-parented)."""
    while True:
        time.sleep(PARENT_POLL_S)
        if os.getppid() != parent:
            os._exit(1)


def _keyed(spec: EpisodeSpec) -> tuple[str, tuple[dict, list[dict], list[dict]]]:
    return spec.key, run_spec(spec)


def require_ray(address: str):
    """The `ray` module, or a refusal saying how to install the optional extra."""
    try:
        import ray
    except ImportError:
        raise InvalidInput(
            "--ray", "a Python with ray installed: pip install 'sortsim[cluster]'", address
        ) from None
    return ray


def _ray(specs: list[EpisodeSpec], address: str, workers: int, on_row: RowCallback) -> None:
    ray = require_ray(address)
    from ray.util import ActorPool

    class EpisodeActor:
        """Keeps the compiled models and renderers alive between episodes: the actor's
        process caches one cell per model settings (`sim.episode.runner.shared_cell`)."""

        def run(self, spec: EpisodeSpec) -> tuple[str, tuple[dict, list[dict], list[dict]]]:
            # the actor's process keeps one cell per catalogue (`shared_cell`)
            return _keyed(spec)

    remote_actor = ray.remote(EpisodeActor)  # @ray.remote, written so that mypy sees it
    ray.init(address=None if address in ("", "local") else address, ignore_reinit_error=True)
    n = max(1, min(workers, len(specs)))
    pool = ActorPool([remote_actor.remote() for _ in range(n)])
    by_key = {spec.key: spec for spec in specs}
    try:
        for key, result in pool.map_unordered(lambda actor, spec: actor.run.remote(spec), specs):
            on_row(by_key[key], *result)
    except Exception as exc:  # Ray wraps an actor's exception: a refusal keeps its one line
        cause = getattr(exc, "cause", None)
        if isinstance(cause, RefusedInput):
            raise cause from None
        raise


def default_workers() -> int:
    """Local worker processes when --workers is not given: the CPUs this process may use."""
    return max(1, len(os.sched_getaffinity(0)))


def run_sweep(
    sweep: SweepConfig,
    out_dir: Path,
    workers: int | None = None,
    ray_address: str | None = None,
    progress: Callable[[str], None] | None = None,
    bar: Callable[[float, str], None] | None = None,
    mix_code: bool = False,
) -> list[dict]:
    """Run the pending episodes of `sweep` into `out_dir`/episodes.csv; returns all rows.

    `progress` gets a line per episode, `bar` the share of the sweep done and its ETA;
    `mix_code` adds to a folder whose episodes ran on other code (`check_code`).

    Raises:
        InvalidInput: `out_dir` is refused (`check_out_dir`), before any episode runs; or an
            episode was refused (in whichever process ran it).
    """
    workers = default_workers() if workers is None else workers
    check(is_integer(workers) and workers >= 1, "--workers", "an integer >= 1", workers)
    check_out_dir(sweep, Path(out_dir), mix_code)
    _start(sweep, Path(out_dir))
    csv_path = Path(out_dir) / "episodes.csv"
    picks_path = Path(out_dir) / PICKS_FILE
    steps_path = Path(out_dir) / TIMELINE_FILE
    todo = pending(sweep, csv_path)
    total, start = len(sweep.episodes), time.perf_counter()
    done_before = total - len(todo)
    if progress:
        progress(f"{sweep.name}: {len(todo)} of {total} episodes to run ({done_before} done)")
    count = [done_before]

    def on_row(spec: EpisodeSpec, row: dict, picks: list[dict], steps: list[dict]) -> None:
        settings = variant_values(spec, sweep.variant_keys)
        row = {**row, "variant": spec.variant, **settings}
        # The picks and timeline first: a sweep killed between the writes leaves rows of an
        # episode without its row, which the next start removes (`_start`); never a row
        # without its picks and timeline.
        key = {c: row.get(c) for c in PICK_KEY_COLUMNS}
        keyed = [{**key, **p, **settings} for p in picks]
        _write_or_stop(outputs.append_sweep_picks, picks_path, keyed, pick_columns(sweep))
        cells = {c: outputs.format_value(c, v) for c, v in (key | settings).items()}
        keyed = [{**cells, **s} for s in steps]
        _write_or_stop(timeline.append_rows, steps_path, timeline_columns(sweep), keyed)
        _write_or_stop(outputs.append_episode, csv_path, row, episode_columns(sweep))
        count[0] += 1
        elapsed = time.perf_counter() - start
        eta = eta_text(elapsed, count[0] - done_before, total - count[0])
        if bar:
            bar(count[0] / total, f"{count[0]}/{total} episodes, {eta}")
        if progress:
            progress(
                f"[{count[0]}/{total}] {spec.key}  accuracy {float(row['accuracy']):.3f}  "
                f"profit {float(row['profit_eur']):.2f} EUR  ({elapsed:.0f} s, {eta})"
            )

    if todo:
        if ray_address is not None:
            _ray(todo, ray_address, workers, on_row)
        else:
            _local(todo, workers, on_row)
    return _sorted_rewrite(sweep, csv_path)


def _write_or_stop(write: Callable, path: Path, *args) -> None:
    """`write(path, *args)`; a failure (a full disk) stops the sweep in one line saying that
    the rows written before are kept and the sweep resumes (`OutputError`)."""
    try:
        write(path, *args)
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        done = len(outputs.read_rows(path.parent / "episodes.csv"))
        kept = f"the {done} episodes written before are"
        kept = "the episode written before is" if done == 1 else kept
        message = (
            f"could not write {path.name} into {path.parent} ({reason}); {kept} kept there: "
            "free some space and run the same command again to resume"
        )
        raise outputs.OutputError(message) from None


def eta_text(elapsed_s: float, done: int, left: int) -> str:
    """'ETA 3 min 20 s': the time the `left` episodes will take at the pace of the `done` ones
    of this run (episodes of unequal cost make it rough; it settles as the sweep goes)."""
    if left <= 0:
        return "done"
    if done <= 0:
        return "ETA unknown"
    seconds = round(elapsed_s / done * left)
    minutes, seconds = divmod(seconds, 60)
    hours, minutes = divmod(minutes, 60)
    if hours:
        return f"ETA {hours} h {minutes} min"
    return f"ETA {minutes} min {seconds} s" if minutes else f"ETA {seconds} s"


def _sorted_rewrite(sweep: SweepConfig, csv_path: Path) -> list[dict]:
    """Rewrite episodes.csv, and picks.csv and timeline.csv beside it, in the grid's order
    (each episode's picks and timeline rows in the order they were made); returns the episode
    rows."""
    rows = outputs.read_rows(csv_path)
    order = {spec.key: i for i, spec in enumerate(sweep.episodes)}

    def grid_order(row: dict) -> int:
        return order.get(row_key(row), len(order))

    rows.sort(key=grid_order)
    if rows:
        outputs.write_episodes(csv_path, rows, episode_columns(sweep))
    picks_path = csv_path.parent / PICKS_FILE
    picks = outputs.read_rows(picks_path)
    if picks:
        ordered = sorted(picks, key=grid_order)  # stable: each episode's picks keep their order
        if ordered != picks:
            outputs.write_sweep_picks(picks_path, ordered, pick_columns(sweep))
    steps_path = csv_path.parent / TIMELINE_FILE
    steps = outputs.read_rows(steps_path)
    ordered = sorted(steps, key=grid_order)
    if ordered != steps:
        timeline.write_rows(steps_path, timeline_columns(sweep), ordered)
    return rows


def mean(values: Iterable[float]) -> float:
    """Mean of `values` (0 for none)."""
    values = list(values)
    return sum(values) / len(values) if values else 0.0
