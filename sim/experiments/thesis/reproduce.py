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

The pieces' contents are made in `reproduce_tables` (tables, the +13 % finding),
`reproduce_bound` (the bound on tables 4.5/4.6's flows), `reproduce_figures` (figures) and
`reproduce_hmm` (table 4.1 and figure 4.1: the stripe HMMs, no sweep) of this package, each
given the run (`reproduce_run`); this module orders them (`PIECES`) and writes their blocks.
"""

from __future__ import annotations

import logging
import re
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from sim.errors import InvalidInput
from sim.experiments.thesis import reproduce_bound as bound
from sim.experiments.thesis import reproduce_calibrated as calibrated
from sim.experiments.thesis import reproduce_figures as figs
from sim.experiments.thesis import reproduce_hmm as hmm
from sim.experiments.thesis import reproduce_paired as paired
from sim.experiments.thesis import reproduce_tables as tables
from sim.experiments.thesis.reproduce_run import Block, Run
from sim.paths import REPO_ROOT
from sim.results import outputs

if TYPE_CHECKING:
    from sim.experiments.sweep_config import SweepConfig

log = logging.getLogger(__name__)

DOCS_FILE = REPO_ROOT / "docs" / "results.md"
"""The docs file whose markers a run fills (`--docs`)."""
DEFAULT_OUT = REPO_ROOT / "runs" / "reproduce"
"""Where the sweeps' folders and the pieces' markdown go (`--out`)."""
END_MARKER = "<!-- /reproduce -->"
"""The line that ends every piece's block in the docs."""


def start_marker(name: str) -> str:
    """The line that starts piece `name`'s block in the docs."""
    return f"<!-- reproduce:{name} -->"


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


_PHYSICAL = ("reproduce_4_5", "reproduce_4_6")
_PAUSED = ("reproduce_4_5_paused", "reproduce_4_6_paused")
_CAMERA = ("reproduce_4_5_camera", "reproduce_4_6_camera")

PIECES = (
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
    Piece("table_4_2", "Table 4.2: pick-and-place accuracy", ("reproduce_4_2",), tables.table_4_2),
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
        _PHYSICAL + _PAUSED,
        figs.figure_4_4,
    ),
    Piece(
        "figure_4_5",
        "Figure 4.5: time against the dataset's size",
        _PHYSICAL + _PAUSED,
        figs.figure_4_5,
    ),
    Piece(
        "figure_4_6",
        "Figure 4.6: profit against the dataset's size",
        _PHYSICAL + _PAUSED,
        figs.figure_4_6,
    ),
    Piece(
        "figure_4_7",
        "Figure 4.7: accuracy of class 2 (paper)",
        _PHYSICAL + _PAUSED,
        figs.figure_4_7,
    ),
    Piece(
        "figure_4_8",
        "Figure 4.8: accuracy of class 3 (plastic)",
        _PHYSICAL + _PAUSED,
        figs.figure_4_8,
    ),
    Piece(
        "figure_4_9",
        "Figure 4.9: accuracy of class 4 (aluminium)",
        _PHYSICAL + _PAUSED,
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
        _PHYSICAL + _PAUSED + _CAMERA + tables.random_sweeps(),
        tables.finding_13,
    ),
    Piece(
        "table_4_2_paused",
        "Table 4.2: pick-and-place accuracy, the thesis's pauses",
        ("reproduce_4_2_paused",),
        tables.table_4_2_paused,
    ),
    Piece(
        "table_4_4_paused",
        "Table 4.4: long-term accuracy, the thesis's pauses",
        ("reproduce_4_4_paused",),
        tables.table_4_4_paused,
    ),
    Piece(
        "table_4_5_calibrated",
        "Table 4.5: x1, the calibrated regime (pauses set to the thesis's items picked per "
        "second); with lookahead and the random picker",
        (calibrated.SWEEPS[0],),
        calibrated.table_4_5_calibrated,
    ),
    Piece(
        "table_4_6_calibrated",
        "Table 4.6: x1.2, the calibrated regime; with lookahead and the random picker",
        (calibrated.SWEEPS[1],),
        calibrated.table_4_6_calibrated,
    ),
    Piece(
        "finding_paired",
        "The +13 % with paired 95 % intervals: qlearning, rollout and lookahead against "
        "proximity and random per dataset and pooled, in the physical, paused and calibrated "
        "regimes; the gain's slope against the items; the thesis's timing",
        tuple(s for _, sweeps, _ in paired.REGIMES for s in sweeps),
        paired.finding_paired,
    ),
    Piece(
        bound.PIECE,
        "The bound on tables 4.5/4.6's flows under the cycle-time model (not proven for the "
        "physics' robot), the best order found with the flow known replayed in physics, and "
        "the planners beside them, per regime; the headroom over proximity with paired 95 % "
        "intervals",
        bound.sweeps(),
        bound.bound_block,
        "the bound per flow (a linear programme, no physics)",
    ),
)
"""Every piece, in the order a whole run makes them (cheap ones first)."""


def pieces() -> dict[str, Piece]:
    """Every piece by name, in `PIECES`' order."""
    return {p.name: p for p in PIECES}


def list_text(quick: bool = False) -> str:
    """`--list`: every piece with what it runs (episodes per sweep at the chosen seeds)."""
    run = Run(DEFAULT_OUT, quick=quick)
    lines: list[str] = []
    sweeps: dict[str, SweepConfig] = {}
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
    """Make the pieces `names` (all when empty; in `PIECES`' order), `echo` them, write them
    to `run.out/<name>.md` and, with `docs`, between their markers there; {name: Block}.

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
    run.piece_sweeps = {p.name: p.sweeps for p in PIECES}
    text = None
    if docs is not None:
        text = Path(docs).read_text(encoding="utf-8")
        for piece in chosen:
            write_block(text, piece.name, "")  # every marker there before any work
    outputs.check_output_dir(run.out, "--out")
    run.check_folders(name for piece in chosen for name in piece.sweeps)
    run.out.mkdir(parents=True, exist_ok=True)
    assert run.figures is not None  # set by Run
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
