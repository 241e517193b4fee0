"""Table 4.1 and figure 4.1 of `sortsim reproduce`: the stripe HMMs, as `sortsim hmm-eval`.

Table 4.1 whole: per class and the average, accuracy, sensitivity, specificity and precision of
the decoded classes against the truth on held-out flows (thesis 4.1.1), on the flows' true codes
and on the codes the belt camera's rendered frames give (`sim.evaluation.camera_recordings`).
The models are the thesis's: five stripe HMMs coupled through their neighbours at t-1, counted
from labelled flows (3.2.2) and re-estimated by Baum-Welch (3.2.3), decoded by the smoothed
posterior; the independent stripes' average is given beside. Camera recordings take about 40 s
a flow; each is kept in `<out>/table_4_1/` and read back when the run is repeated.

Figure 4.1: k-means (thesis 3.4, 4.1.2) on a 20-row batch of a held-out flow's decoded grid,
expanded to 25 columns: each class's cells, its clusters' centroids, and the true items' centres.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sim.experiments.thesis.reproduce_run import Block
from sim.paths import temporary_path

if TYPE_CHECKING:
    from sim.experiments.thesis.reproduce_run import Run

TRUTH_SEEDS = (range(0, 12), range(200, 212), range(100, 112))
"""Labelled training, unlabelled and held-out flows on true codes (as `sortsim hmm-eval`)."""
CAMERA_SEEDS = (range(0, 4), (), range(100, 102))
"""The same on camera codes (rendered: about 40 s a flow)."""
CAMERA_QUICK_SEEDS = (range(0, 2), (), range(100, 101))
"""Camera codes under `--quick`."""
FIGURE_SEED, FIGURE_ROWS = 100, (20, 40)
"""Figure 4.1's held-out flow and batch of rows."""


@dataclass(frozen=True)
class Scores:
    """Table 4.1 of one kind of codes.

    Attributes:
        coupled: (5, 4) the coupled stripes' table (classes 1-4, Average; four statistics).
        independent: (5, 4) the independent stripes' table.
        flows: The seeds (training, unlabelled, held-out).
        rows: Held-out rows scored (x 5 stripes).
        refused: Camera frames the pipeline refused (their row's codes repeated).
    """

    coupled: np.ndarray
    independent: np.ndarray
    flows: tuple
    rows: int
    refused: int = 0


def _span(seeds) -> str:
    seeds = list(seeds)
    if not seeds:
        return "none"
    return f"{seeds[0]}-{seeds[-1]}" if len(seeds) > 1 else f"{seeds[0]}"


def recordings(seeds, kind: str, cache: Path | None = None) -> list:
    """The recordings of `seeds` (`sim.flow.labelled_grids.Recording`): true codes, or camera
    codes (each kept as `<cache>/camera_<seed>.npz` and read back)."""
    from sim.flow.catalogue import load_catalogue
    from sim.flow.labelled_grids import Recording, record

    catalogue = load_catalogue()
    if kind == "truth":
        return [record(s, catalogue) for s in seeds]
    from sim.evaluation.camera_recordings import camera_recording

    out = []
    for seed in seeds:
        path = None if cache is None else Path(cache) / f"camera_{seed}.npz"
        if path is not None and path.exists():
            with np.load(path) as data:
                fields = {k: data[k] for k in data.files}
            out.append(Recording(**{k: v.item() if v.ndim == 0 else v for k, v in fields.items()}))
            continue
        rec = camera_recording(seed, catalogue)
        if path is not None:  # written to a temporary, renamed: a killed run leaves none
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = temporary_path(path, ".npz")
            arrays: dict[str, Any] = {k: np.asarray(v) for k, v in vars(rec).items()}
            np.savez(tmp, **arrays)
            os.replace(tmp, path)
        out.append(rec)
    return out


def scores(seeds: tuple, kind: str, cache: Path | None = None) -> Scores:
    """Train on `seeds` (training, unlabelled, held-out) and score table 4.1 both ways."""
    from perception.hmm.evaluation import train_and_score

    train, extra, test = (recordings(s, kind, cache) for s in seeds)
    results = train_and_score(
        [r.classes for r in train],
        [r.codes for r in train],
        [r.codes for r in extra],
        [r.classes for r in test],
        [r.codes for r in test],
    )
    return Scores(
        results[True, "re-estimated"][1].table,
        results[False, "re-estimated"][1].table,
        seeds,
        sum(r.classes.shape[0] for r in test),
        sum(r.refused_rows for r in train + extra + test),
    )


def markdown_table(ours: np.ndarray) -> list[str]:
    """Table 4.1 in markdown, every cell `ours (thesis)`."""
    from perception.codes import CLASS_NAMES
    from perception.hmm.metrics import STATS, THESIS_TABLE_4_1

    lines = ["| class | " + " | ".join(STATS) + " |", "|---|" + "---|" * len(STATS)]
    labels = [f"{i + 1} {name}" for i, name in enumerate(CLASS_NAMES)] + ["**average**"]
    for r, label in enumerate(labels):
        cells = [f"{ours[r, c]:.4f} ({THESIS_TABLE_4_1[r, c]:.4f})" for c in range(len(STATS))]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return lines


def table_4_1(run: Run) -> Block:
    """Table 4.1 on true codes and on camera codes (coupled stripes, re-estimated)."""
    from sim.cell.rendering import check_backend

    check_backend()
    camera_seeds = CAMERA_QUICK_SEEDS if run.quick else CAMERA_SEEDS
    made = {
        "truth": scores(TRUTH_SEEDS, "truth"),
        "camera": scores(camera_seeds, "camera", run.out / "table_4_1"),
    }
    what = "held-out flows of `sortsim hmm-eval`'s generator (varied world; camera: rendered)"
    text = [run.label("table_4_1", what), ""]
    for kind, s in made.items():
        train, extra, test = (_span(x) for x in s.flows)
        codes = "the flows' true codes" if kind == "truth" else "the camera's codes"
        text += [
            f"On {codes} (coupled stripes, re-estimated, posterior decoding; training flows "
            f"{train}, unlabelled {extra}, held out {test}: {s.rows} rows x 5 stripes"
            + (f", {s.refused} camera frames refused" if kind == "camera" else "")
            + "); cells ours (thesis):",
            "",
            *markdown_table(s.coupled),
            "",
            f"Independent stripes: average accuracy {s.independent[4, 0]:.4f}, sensitivity "
            f"{s.independent[4, 1]:.4f}, specificity {s.independent[4, 2]:.4f}, precision "
            f"{s.independent[4, 3]:.4f}.",
            "",
        ]
    return Block("\n".join(text).rstrip("\n"))


def figure_4_1(run: Run) -> Block:
    """Figure 4.1: one held-out batch's clusters and centroids per class."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from perception.codes import CLASS_NAMES
    from perception.hmm.stripes import infer
    from perception.hmm.training import TrainConfig, train
    from perception.items.from_grid import GridGeometry, expand_grid, items_kmeans
    from sim.sensing.stripe_hmms import item_sizes

    labelled = recordings(TRUTH_SEEDS[0], "truth")
    extra = recordings(TRUTH_SEEDS[1], "truth")
    classes, codes = [r.classes for r in labelled], [r.codes for r in labelled]
    _, models = train(classes, codes, [r.codes for r in extra], TrainConfig(coupled=True))
    rec = recordings([FIGURE_SEED], "truth")[0]
    post = infer(models, rec.codes.T)["smoothed"].transpose(1, 0, 2)
    decoded = np.argmax(post, axis=2) + 1
    first, last = FIGURE_ROWS
    geo = GridGeometry(row_pitch_m=rec.row_pitch_m)
    found = items_kmeans(decoded[first:last], geo, item_sizes(labelled), first_row=first)
    expanded = expand_grid(decoded[first:last])
    fig, axes = plt.subplots(1, 3, figsize=(11, 5), sharey=True)
    colours = {2: "tab:brown", 3: "tab:blue", 4: "tab:grey"}
    rows_of = rec.item_b / rec.row_pitch_m
    for ax, cls in zip(axes, (2, 3, 4), strict=True):
        r, c = np.nonzero(expanded == cls)
        ax.scatter(c, r + first, marker="s", s=30, color=colours[cls], alpha=0.35, label="cells")
        mine = found.class_id == cls
        cols = (found.y[mine] + geo.belt_half_width_m) / geo.column_width_m + 0.5
        ax.scatter(
            cols,
            found.b[mine] / geo.row_pitch_m,
            marker="o",
            s=80,
            facecolors="none",
            edgecolors="k",
            label="k-means centroids",
        )
        true = (rec.item_class == cls) & (rows_of >= first) & (rows_of < last)
        tcols = (rec.item_y[true] + geo.belt_half_width_m) / geo.column_width_m + 0.5
        ax.scatter(tcols, rows_of[true], marker="x", color="r", label="true centres")
        ax.set_title(f"class {cls}: {CLASS_NAMES[cls - 1]}")
        ax.set_xlim(0, 26)
        ax.set_xlabel("expanded column (1-25; 0 and 26 the bins)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("grid row (0.5 s each)")
    axes[0].invert_yaxis()
    axes[0].legend(fontsize=8)
    fig.suptitle(
        f"Figure 4.1: k-means on rows {first}-{last - 1} of held-out flow {FIGURE_SEED} "
        "(decoded by the coupled stripe HMMs, true codes)",
        fontsize=10,
    )
    fig.tight_layout()
    assert run.figures is not None  # set by Run
    path = run.figures / "figure_4_1.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    n_true = int(((rows_of >= first) & (rows_of < last)).sum())
    what = f"held-out flow {FIGURE_SEED}, rows {first}-{last - 1}"
    text = [
        run.label("figure_4_1", what),
        "",
        f"{len(found)} centroids found for {n_true} true items in the batch.",
        "",
        run.figure(path, "Figure 4.1: clusters and centroids per class"),
    ]
    return Block("\n".join(text), (path,))
