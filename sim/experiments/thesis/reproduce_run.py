"""What the pieces of `sortsim reproduce` share: the run (`Run`) and what a piece makes (`Block`).

A `Run` knows where things go and how many seeds each sweep runs (the sweep file's, the
thesis's counts, or `QUICK_SEEDS` under `--quick`); it runs a sweep the first time a piece asks
for its rows (resuming, `sim.experiments.sweep_runner`) and labels each block with the command,
commit and code digest it ran on. The pieces themselves are in `reproduce_tables`,
`reproduce_figures` and `reproduce_hmm`; `sim.experiments.thesis.reproduce` orders and writes them.
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from sim.experiments import sweep_config
from sim.experiments import sweep_runner as runner
from sim.paths import EXPERIMENTS_DIR
from sim.results import code_digest

log = logging.getLogger("sim.experiments.thesis.reproduce")

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
"""Seeds per grid point of each sweep under `--quick`."""


@dataclass(frozen=True)
class Block:
    """What a piece made.

    Attributes:
        markdown: The block written between its markers (tables, readings of numbers, figure
            links relative to the docs file).
        figures: The PNG files written.
    """

    markdown: str
    figures: tuple[Path, ...] = ()


@dataclass
class Run:
    """One `sortsim reproduce`: where things go, how many seeds, the sweeps' rows once run.

    Attributes:
        out: The sweeps' folders and the pieces' markdown.
        quick: `QUICK_SEEDS` instead of the sweep files' seed counts.
        workers: Local worker processes per sweep (None: the CPUs).
        ray: A Ray cluster's address, or None for local workers.
        figures: Where the PNGs go (None: `<out>/figures`).
        link: How the docs file reaches `figures` ("results/": docs/results/).
        command: The command line that makes a piece (its name filled in), for the labels.
        experiments: Where the sweep files are (`<name>.toml`).
        mix_code: Add to sweep folders whose episodes ran on other code (another code digest,
            `sim.results.code_digest`); refused without it, and the blocks then say they mix.
        piece_sweeps: The sweeps each piece reads (`reproduce.PIECES`), for its label's code
            digests; a piece not in it is labelled with every sweep this run has read.
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
    piece_sweeps: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
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
            runner.check_out_dir(sweep, folder, self.mix_code)
            runner.write_manifest(sweep, folder)
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
        per = {n: self.seeds_of.get(n) or sorted(set(runner.seeds(self.sweep(n)))) for n in names}
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
        """Episodes per code digest among the rows of the sweeps piece `piece` reads."""
        sweeps = self.piece_sweeps.get(piece, tuple(self._rows))
        rows = [r for name in sweeps for r in self._rows.get(name, [])]
        return code_digest.digests_of(rows)

    def figure(self, path: Path, alt: str) -> str:
        """A markdown image link to `path` (in `figures`) from the docs file."""
        return f"![{alt}]({self.link}{path.name})"


def _check_camera(sweep: sweep_config.SweepConfig) -> None:
    """Refuse, before the sweep's first episode, what its camera episodes cannot run without
    (the rendering back-end, the camera's calibration)."""
    if not any(s.config.perception == "camera" for s in sweep.episodes):
        return
    from perception.camera.calibration import CameraCalibration
    from sim.cell.camera import DEFAULT_CALIBRATION
    from sim.cell.rendering import check_backend

    CameraCalibration.load(DEFAULT_CALIBRATION)
    check_backend()
