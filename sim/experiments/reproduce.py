"""The thesis's chapter 4 reproduced by one command (`sortsim reproduce`).

Every table of chapter 4 (4.1-4.6, with the paused and camera variants) and every figure our
data can make (4.1, 4.2, 4.4-4.9) is a `Piece`: a name (`table_4_5`), a title, the sweeps it
reads (`experiments/reproduce_*.toml`, run through `sim.experiments.sweep_runner`: resumable,
local workers or Ray) and a function that turns their rows into a markdown block of tables
(ours beside the thesis's numbers) and figure links. A run

1. runs the sweeps the chosen pieces need, each into `<out>/<sweep name>/` (an episode already
   in its `episodes.csv` is skipped: rerunning resumes), with the thesis's seed counts, or with
   `QUICK_SEEDS` under `--quick`; a folder whose episodes ran on other code (another
   `code_digest` in its rows, `sim.results.code_digest`) is refused in one line before any
   work, every folder checked first, unless `--mix-code` (`Run.mix_code`) says to add to it;
2. makes each piece from the rows of the seeds it ran (a folder holding more seeds than asked
   is read for the asked ones only), prints it, writes it to `<out>/<name>.md` and its figures
   beside the docs (`docs/results/`, or `<out>/figures/` without docs); its first line names
   the command, the commit and code digest it ran on, and, when its episodes' rows carry
   other digests too, says MIXED CODE with each digest's episode count (`Run.label`);
3. writes each block into the docs file between its markers, `<!-- reproduce:NAME -->` and the
   next `<!-- /reproduce -->` (`write_block`): nothing outside the markers changes, and writing
   the same block twice changes nothing.

The pieces' contents are made in `sim.experiments.reproduce_tables` (tables, the +13 % finding),
`sim.experiments.reproduce_figures` (figures) and `sim.experiments.reproduce_hmm` (table 4.1 and
figure 4.1: the stripe HMMs, no sweep).
"""

from __future__ import annotations

import logging
import re
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from sim.errors import InvalidInput
from sim.experiments import sweep_config
from sim.experiments import sweep_runner as runner
from sim.experiments.reproduce_tables import Block
from sim.paths import EXPERIMENTS_DIR, REPO_ROOT
from sim.results import code_digest, outputs

log = logging.getLogger(__name__)

DOCS_FILE = REPO_ROOT / "docs" / "results.md"
"""The docs file whose markers a run fills (`--docs`)."""
DEFAULT_OUT = REPO_ROOT / "runs" / "reproduce"
"""Where the sweeps' folders and the pieces' markdown go (`--out`)."""
END_MARKER = "<!-- /reproduce -->"
"""The line that ends every piece's block in the docs."""

QUICK_SEEDS = {
    "reproduce_4_2": 1,
    "reproduce_4_3": 1,
    "reproduce_4_3_paused": 1,
    "reproduce_4_4": 1,
    "reproduce_4_5": 1,
    "reproduce_4_6": 1,
    "reproduce_4_5_paused": 1,
    "reproduce_4_6_paused": 1,
    "reproduce_4_5_camera": 1,
    "reproduce_4_6_camera": 1,
    "reproduce_4_5_random": 1,
    "reproduce_4_6_random": 1,
    "reproduce_4_5_paused_random": 1,
    "reproduce_4_6_paused_random": 1,
    "reproduce_objectives": 2,
}
"""Seeds per grid point of each sweep under `--quick` (the full run: the sweep file's, the
thesis's counts)."""


def start_marker(name: str) -> str:
    """The line that starts piece `name`'s block in the docs."""
    return f"<!-- reproduce:{name} -->"


@dataclass
class Run:
    """One `sortsim reproduce`: where things go, how many seeds, the sweeps' rows once run.

    Attributes:
        out: The sweeps' folders and the pieces' markdown.
        quick: `QUICK_SEEDS` instead of the sweep files' seed counts.
        workers: Local worker processes per sweep (None: the CPUs).
        ray: A Ray cluster's address, or None for local workers.
        figures: Where the PNGs go.
        link: How the docs file reaches `figures` ("results/": docs/results/).
        command: The command line that makes a piece (its name filled in), for the labels.
        experiments: Where the sweep files are (`<name>.toml`).
        mix_code: Add to sweep folders whose episodes ran on other code (another code digest,
            `sim.results.code_digest`); refused without it, and the blocks then say they mix.
    """

    out: Path
    quick: bool = False
    workers: int | None = None
    ray: str | None = None
    figures: Path | None = None
    link: str = ""
    command: str = "sortsim reproduce"
    experiments: Path = EXPERIMENTS_DIR
    mix_code: bool = False
    _rows: dict[str, list[dict]] = field(default_factory=dict)
    _sweeps: dict[str, sweep_config.SweepConfig] = field(default_factory=dict)
    seeds_of: dict[str, list[int]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.out = Path(self.out)
        if self.figures is None:
            self.figures = self.out / "figures"

    def sweep(self, name: str) -> sweep_config.SweepConfig:
        """The sweep `name` (`experiments/<name>.toml`) with this run's seeds (read once)."""
        if name not in self._sweeps:
            sweep = sweep_config.load(Path(self.experiments) / f"{name}.toml")
            if self.quick:
                sweep = sweep_config.first_seeds(sweep, QUICK_SEEDS.get(name, 1))
            self._sweeps[name] = sweep
        return self._sweeps[name]

    def check_folders(self, names) -> None:
        """Refuse, before any work, a folder of the sweeps `names` that their run could not use
        (`sweep_runner.check_out_dir`: another sweep's rows, or, without `mix_code`, rows of
        other code)."""
        for name in dict.fromkeys(names):
            folder = self.out / name
            if (folder / "episodes.csv").exists():
                runner.check_out_dir(self.sweep(name), folder, self.mix_code)

    def rows(self, name: str) -> list[dict]:
        """The rows of sweep `name` for this run's seeds, the sweep run first (resuming)."""
        if name not in self._rows:
            sweep = self.sweep(name)
            folder = self.out / name
            _check_camera(sweep)
            _write_manifest(sweep, folder, self.mix_code)
            tic = time.perf_counter()
            rows = runner.run_sweep(
                sweep,
                folder,
                self.workers,
                self.ray,
                progress=log.info,
                bar=None,
                mix_code=self.mix_code,
            )
            keys = {spec.key for spec in sweep.episodes}
            self._rows[name] = [r for r in rows if runner.row_key(r) in keys]
            self.seeds_of[name] = sorted({spec.config.seed for spec in sweep.episodes})
            log.info("%s: %d episodes (%.0f s)", name, len(keys), time.perf_counter() - tic)
        return self._rows[name]

    def seeds_text(self, *names: str) -> str:
        """'seeds 0-4 (5 per grid point)' of the sweeps `names` as this run runs them."""
        per = {n: self.seeds_of.get(n) or _seeds(self, n) for n in names}
        seeds = sorted({s for v in per.values() for s in v})
        span = f"{seeds[0]}-{seeds[-1]}" if len(seeds) > 1 else f"{seeds[0]}"
        each = "/".join(str(c) for c in sorted({len(v) for v in per.values()}))
        return f"seeds {span} ({each} per grid point)"

    def label(self, piece: str, what: str) -> str:
        """The block's first line: how it was made (so a quick run's numbers say so), the
        commit and code digest it ran on and, when its episodes ran on other code too, their
        digests (`code_digest.provenance`)."""
        cmd = f"{self.command} --only {piece}" + (" --quick" if self.quick else "")
        cmd += " --mix-code" if self.mix_code else ""
        ran = code_digest.provenance(
            self.digests(piece),
            code_digest.code_digest(),
            code_digest.commit_text(code_digest.code_commit()),
        )
        return f"*Generated by `{cmd}` from {ran}: {what}. Not edited by hand.*"

    def digests(self, piece: str) -> Counter:
        """Episodes per code digest among the rows piece `piece` reads (the rows of its sweeps
        this run has read; none for a piece without sweeps)."""
        piece_sweeps = pieces()[piece].sweeps if piece in pieces() else tuple(self._rows)
        rows = [r for name in piece_sweeps for r in self._rows.get(name, [])]
        return code_digest.digests_of(rows)

    def figure(self, path: Path, alt: str) -> str:
        """A markdown image link to `path` (in `figures`) from the docs file."""
        return f"![{alt}]({self.link}{path.name})"


def _seeds(run: Run, name: str) -> list[int]:
    return sorted({spec.config.seed for spec in run.sweep(name).episodes})


def _check_camera(sweep: sweep_config.SweepConfig) -> None:
    """Refuse, before the sweep's first episode, what its camera episodes cannot run without
    (the rendering back-end, the camera's calibration, the item classifier's training table),
    and record a custom catalogue's classifier table once (as `sortsim sweep` does)."""
    camera = [s.config for s in sweep.episodes if s.config.perception == "camera"]
    if not camera:
        return
    from perception.camera.calibration import CameraCalibration
    from sim.cell.camera import DEFAULT_CALIBRATION
    from sim.cell.rendering import check_backend
    from sim.evaluation.item_features import prepare_camera

    CameraCalibration.load(DEFAULT_CALIBRATION)
    check_backend()
    seen = set()
    for config in camera:
        key = (config.catalogue, repr(config.flow), config.classifier)
        if key not in seen:
            seen.add(key)
            prepare_camera(config)


def _write_manifest(sweep: sweep_config.SweepConfig, folder: Path, mix_code: bool) -> None:
    """The sweep's manifest.json (as `sortsim sweep` writes it), once its folder is checked."""
    from sim.results import manifest

    runner.check_out_dir(sweep, folder, mix_code)
    folder.mkdir(parents=True, exist_ok=True)
    config = _manifest_config(sweep)
    seeds = [spec.config.seed for spec in sweep.episodes]
    manifest.write(folder, manifest.build("sweep", config, seeds))


def _manifest_config(sweep: sweep_config.SweepConfig) -> dict:
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


@dataclass(frozen=True)
class Piece:
    """One table or figure of the thesis's chapter 4.

    Attributes:
        name: Its marker and `--only` name (`table_4_5`).
        title: What it is, in words.
        sweeps: The sweeps it reads (`experiments/<name>.toml`).
        make: (run) -> `Block`.
        extra: Work besides the sweeps, in words (for `--list`).
    """

    name: str
    title: str
    sweeps: tuple[str, ...]
    make: Callable[[Run], Block]
    extra: str = ""


def pieces() -> dict[str, Piece]:
    """Every piece by name, in the order a whole run makes them (cheap ones first)."""
    from sim.experiments import reproduce_figures as figs
    from sim.experiments import reproduce_hmm as hmm
    from sim.experiments import reproduce_tables as tables

    paused = ("reproduce_4_5_paused", "reproduce_4_6_paused")
    physical = ("reproduce_4_5", "reproduce_4_6")
    camera = ("reproduce_4_5_camera", "reproduce_4_6_camera")
    random = tables.random_sweeps()
    out = [
        Piece(
            "table_4_1",
            "Table 4.1: the stripe HMMs per class and average (accuracy, sensitivity, "
            "specificity, precision), on true codes and on camera codes",
            (),
            hmm.table_4_1,
            "stripe HMMs trained and scored on generated flows; camera codes rendered",
        ),
        Piece(
            "figure_4_1",
            "Figure 4.1: k-means clusters of each class and their centroids on a 20-row batch",
            (),
            hmm.figure_4_1,
            "a held-out flow's decoded grid",
        ),
        Piece(
            "figure_4_2",
            "Figure 4.2: accuracy and profit of the three objectives (v/d, d = 1, v = 1), at "
            "the planner level and in episodes",
            ("reproduce_objectives",),
            figs.figure_4_2,
            "the kinematic belt (planner level)",
        ),
        Piece(
            "figure_4_3",
            "Figure 4.3: the pick order and path of each objective on one busy belt",
            (),
            figs.figure_4_3,
            "the kinematic belt (planner level)",
        ),
        Piece(
            "table_4_2", "Table 4.2: pick-and-place accuracy", ("reproduce_4_2",), tables.table_4_2
        ),
        Piece(
            "table_4_3",
            "Table 4.3: extreme values, physical cycle",
            ("reproduce_4_3",),
            tables.table_4_3,
        ),
        Piece(
            "table_4_3_paused",
            "Table 4.3: extreme values, the thesis's pauses",
            ("reproduce_4_3_paused",),
            tables.table_4_3_paused,
        ),
        Piece(
            "table_4_5",
            "Table 4.5: x1, physical cycle; with the random picker's rows",
            ("reproduce_4_5", "reproduce_4_5_random"),
            tables.table_4_5,
        ),
        Piece(
            "table_4_6",
            "Table 4.6: x1.2, physical cycle; with the random picker's rows",
            ("reproduce_4_6", "reproduce_4_6_random"),
            tables.table_4_6,
        ),
        Piece(
            "table_4_5_paused",
            "Table 4.5: x1, the thesis's pauses; with the random picker's rows",
            ("reproduce_4_5_paused", "reproduce_4_5_paused_random"),
            tables.table_4_5_paused,
        ),
        Piece(
            "table_4_6_paused",
            "Table 4.6: x1.2, the thesis's pauses; with the random picker's rows",
            ("reproduce_4_6_paused", "reproduce_4_6_paused_random"),
            tables.table_4_6_paused,
        ),
        Piece(
            "figure_4_4",
            "Figure 4.4: accuracy against the dataset's size",
            physical + paused,
            figs.figure_4_4,
        ),
        Piece(
            "figure_4_5",
            "Figure 4.5: time against the dataset's size",
            physical + paused,
            figs.figure_4_5,
        ),
        Piece(
            "figure_4_6",
            "Figure 4.6: profit against the dataset's size",
            physical + paused,
            figs.figure_4_6,
        ),
        Piece(
            "figure_4_7",
            "Figure 4.7: accuracy of class 2 (paper)",
            physical + paused,
            figs.figure_4_7,
        ),
        Piece(
            "figure_4_8",
            "Figure 4.8: accuracy of class 3 (plastic)",
            physical + paused,
            figs.figure_4_8,
        ),
        Piece(
            "figure_4_9",
            "Figure 4.9: accuracy of class 4 (aluminium)",
            physical + paused,
            figs.figure_4_9,
        ),
        Piece(
            "table_4_4",
            "Table 4.4: long-term accuracy, 3000 items over 25 min",
            ("reproduce_4_4",),
            tables.table_4_4,
        ),
        Piece(
            "table_4_5_camera",
            "Table 4.5 end to end through the camera: truth, camera with the stripe HMMs, "
            "camera with the fused classifier",
            ("reproduce_4_5", "reproduce_4_5_camera"),
            tables.table_4_5_camera,
        ),
        Piece(
            "table_4_6_camera",
            "Table 4.6 end to end through the camera",
            ("reproduce_4_6", "reproduce_4_6_camera"),
            tables.table_4_6_camera,
        ),
        Piece(
            "finding_13",
            "The thesis's +13 % profit of Q-learning over proximity: by regime, speed and "
            "density, with the profit split into picks and value per pick; each planner "
            "against the random picker",
            physical + paused + camera + random,
            tables.finding_13,
        ),
    ]
    return {p.name: p for p in out}


def list_text(quick: bool = False) -> str:
    """`--list`: every piece with what it runs (episodes per sweep at the chosen seeds)."""
    run = Run(DEFAULT_OUT, quick=quick)
    lines, sweeps = [], {}
    for piece in pieces().values():
        for name in piece.sweeps:
            sweeps.setdefault(name, run.sweep(name))
        parts = [f"{s} ({len(sweeps[s].episodes)} episodes)" for s in piece.sweeps]
        if piece.extra:
            parts.append(piece.extra)
        lines.append(f"{piece.name:<18} {piece.title}")
        lines.append(f"{'':<18} from: {'; '.join(parts)}")
    configs = [spec.config for sweep in sweeps.values() for spec in sweep.episodes]
    hours = {
        kind: sum(c.duration_s for c in configs if c.perception == kind) / 3600
        for kind in ("truth", "camera")
    }
    lines.append(
        f"\n{len(sweeps)} sweeps, {len(configs)} episodes ({'--quick' if quick else 'the thesis'}"
        f"'s seeds): flows of {hours['truth']:.1f} h in truth perception and "
        f"{hours['camera']:.1f} h through the camera, simulated"
    )
    return "\n".join(lines)


def write_block(text: str, name: str, body: str) -> str:
    """`text` with the lines between piece `name`'s start marker and the next end marker
    replaced by `body`; everything else as it was (idempotent: writing the same body again
    gives the same text).

    Args:
        text: The docs file's text.
        name: The piece's name (`start_marker`).
        body: The block (without markers).

    Returns:
        The new text.

    Raises:
        InvalidInput: the start marker is missing or twice there, no end marker follows it, or
            `body` holds a marker.
    """
    start = start_marker(name)
    if start in body or END_MARKER in body or "<!-- reproduce:" in body:
        raise InvalidInput("block", "markdown without reproduce markers", name)
    found = [m.start() for m in re.finditer(re.escape(start), text)]
    if len(found) != 1:
        allowed = f"one line {start} ... {END_MARKER} in the docs file"
        raise InvalidInput(name, allowed, f"{len(found)} start markers")
    head_end = text.index("\n", found[0]) + 1 if "\n" in text[found[0] :] else len(text)
    end = text.find(END_MARKER, head_end)
    if end < 0:
        raise InvalidInput(name, f"an end marker {END_MARKER} after {start}", "none")
    return text[:head_end] + body.strip("\n") + "\n" + text[end:]


def markers_in(text: str) -> list[str]:
    """The piece names whose start markers `text` holds, in order."""
    return re.findall(r"<!-- reproduce:([A-Za-z0-9_]+) -->", text)


def reproduce(
    names: list[str], run: Run, docs: Path | None = DOCS_FILE, echo: Callable[[str], None] = print
) -> dict[str, Block]:
    """Make the pieces `names` (in `pieces()`'s order), print them, write them to
    `run.out/<name>.md` and, with `docs`, between their markers there.

    Args:
        names: Piece names (every one when empty).
        run: Where and how (`Run`).
        docs: The docs file to fill, or None.
        echo: Where each block is printed.

    Returns:
        {name: Block}.

    Raises:
        InvalidInput: an unknown name; a docs file without a piece's markers; a sweep folder
            its sweep cannot use (another sweep's, or, without `run.mix_code`, of other code);
            all checked before any work.
    """
    catalogue = pieces()
    unknown = [n for n in names if n not in catalogue]
    if unknown:
        raise InvalidInput("--only", "names of --list: " + ", ".join(catalogue), unknown)
    chosen = [p for p in catalogue.values() if not names or p.name in names]
    text = None
    if docs is not None:
        text = Path(docs).read_text(encoding="utf-8")
        for piece in chosen:
            write_block(text, piece.name, "")  # every marker there before any work
    outputs.check_output_dir(run.out, "--out")
    run.check_folders(name for piece in chosen for name in piece.sweeps)
    run.out.mkdir(parents=True, exist_ok=True)
    run.figures.mkdir(parents=True, exist_ok=True)
    made = {}
    for piece in chosen:
        tic, cpu = time.perf_counter(), time.process_time()
        block = piece.make(run)
        made[piece.name] = block
        took = time.perf_counter() - tic
        echo(f"\n## {piece.name}: {piece.title} ({took:.0f} s)\n\n{block.markdown}")
        outputs.write_atomic(run.out / f"{piece.name}.md", block.markdown.strip() + "\n")
        if docs is not None:
            text = write_block(Path(docs).read_text(encoding="utf-8"), piece.name, block.markdown)
            outputs.write_atomic(Path(docs), text)
        log.info(
            "%s: %.0f s (this process's CPU %.0f s)", piece.name, took, time.process_time() - cpu
        )
    return made
