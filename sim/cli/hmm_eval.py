"""`sortsim hmm-eval`: train the stripe HMMs on some seeds, score them on others (table 4.1).

Training follows the thesis: supervised counts on the labelled training recordings (3.2.2), then
Baum-Welch on the codes of those and of further unlabelled generated recordings (3.2.3). The
held-out recordings are decoded and scored per class, one-vs-rest, averaged over the 5 stripe
HMMs (4.1.1); the thesis's value stands in brackets beside each of ours. Independent and
neighbour-coupled stripes are both trained and compared, and the decoded grids are turned into
items by k-means and by connected components, scored against the flow's true items.
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sortsim hmm-eval`."""
    parser.add_argument(
        "--perception",
        default="truth",
        choices=["truth", "camera"],
        help="score on true observation codes or on camera codes",
    )
    parser.add_argument(
        "--train-seeds", default=None, help="labelled training flows (0-11; camera: 0-3)"
    )
    parser.add_argument(
        "--extra-seeds",
        default=None,
        help="unlabelled flows for re-estimation, '' for none (200-211; camera: none)",
    )
    parser.add_argument(
        "--test-seeds", default=None, help="held-out flows (100-111; camera: 100-101)"
    )
    parser.add_argument("--iterations", type=int, default=5, help="Baum-Welch iterations (5)")
    parser.add_argument("--tol", type=float, default=1e-2, help="likelihood gain to stop [nats]")
    parser.add_argument(
        "--anchor",
        type=float,
        default=0.0,
        help="pseudo-counts per row toward the counted model (0)",
    )
    parser.add_argument("--smoothing", type=float, default=0.5, help="additive smoothing (0.5)")
    parser.add_argument("--decode", default="posterior", choices=["posterior", "filtered"])
    parser.add_argument(
        "--coupling",
        default="off",
        choices=["off", "on"],
        help="which model's table to print (both are compared)",
    )
    parser.add_argument("--no-items", action="store_true", help="skip the item extraction")
    parser.add_argument(
        "--batch-rows", type=int, default=20, help="rows per k-means batch (20, thesis 3.4)"
    )
    parser.add_argument("--save", default=None, help="write the printed model to this .npz")


# (option, with true codes, with camera codes): camera recordings run the physics and the
# renderer for every row (about 40 s a flow), so the camera defaults are fewer flows.
DEFAULT_SEEDS = (
    ("train_seeds", "0-11", "0-3"),
    ("extra_seeds", "200-211", ""),
    ("test_seeds", "100-111", "100-101"),
)


MAX_SEEDS = 1000
"""Most seeds (flows) per seed option."""
MAX_SEED = 2**32 - 1


def parse_seed_option(text: str, field: str) -> list[int]:
    """Seeds from '0-9', '3,5,8' or '0-4,10', refused before the list is built when it would
    hold more than `MAX_SEEDS` or a seed outside 0..2^32-1."""
    from sim.errors import InvalidInput
    from sim.flow.labelled_grids import parse_seeds

    allowed = f"seeds like 0-9 or 1,4,7 (integers 0..{MAX_SEED}, at most {MAX_SEEDS})"
    count = 0
    for part in text.split(","):
        lo, _, hi = part.strip().partition("-")
        try:
            first, last = int(lo), int(hi or lo)
        except ValueError:
            raise InvalidInput(field, allowed, text) from None
        if not 0 <= first <= last <= MAX_SEED:
            raise InvalidInput(field, allowed, text)
        count += last - first + 1
        if count > MAX_SEEDS:
            raise InvalidInput(field, allowed, text)
    return parse_seeds(text, field)


def check(args: argparse.Namespace) -> None:
    """Refuse, before any training, options the evaluation cannot use."""
    import math

    from sim.errors import InvalidInput

    def number(name: str, ok, allowed: str) -> None:
        value = getattr(args, name)
        if not (math.isfinite(value) and ok(value)):
            raise InvalidInput("--" + name.replace("_", "-"), allowed, value)

    if not 0 <= args.iterations <= 1000:
        raise InvalidInput("--iterations", "0..1000", args.iterations)
    number("tol", lambda v: v >= 0, "a finite gain >= 0 [nats]")
    number("anchor", lambda v: v >= 0, "a finite pseudo-count >= 0")
    number("smoothing", lambda v: v > 0, "a finite pseudo-count > 0")
    if not 1 <= args.batch_rows <= 1000:
        raise InvalidInput("--batch-rows", "1..1000", args.batch_rows)
    if args.save is not None:
        from sim.results import outputs

        save = Path(args.save)
        if not args.save.strip() or args.save.endswith(("/", os.sep)) or save.is_dir():
            raise InvalidInput("--save", "an .npz file path, not a folder", args.save)
        save = save if save.suffix == ".npz" else save.with_name(save.name + ".npz")
        outputs.check_output_file(save, "--save", (".npz",), "an .npz file")
    if args.perception == "camera":
        from perception.camera.calibration import CameraCalibration
        from sim.cell.camera import DEFAULT_CALIBRATION
        from sim.cell.rendering import check_backend

        CameraCalibration.load(DEFAULT_CALIBRATION)
        check_backend()


def _recordings(seeds, catalogue, perception):
    if perception == "camera":
        from sim.evaluation.camera_recordings import camera_recording as record
    else:
        from sim.flow.labelled_grids import record
    return [record(s, catalogue) for s in seeds]


def _items(train, test, evaluation, batch_rows):

    from perception.items.from_grid import GridGeometry, items_components, items_kmeans
    from perception.items.scoring import pooled, score_items
    from sim.sensing.stripe_hmms import item_sizes

    size = item_sizes(train)
    scores = {}
    for source in ("decoded", "true"):
        for name in ("k-means", "components"):
            scores[source, name] = []
        grids = evaluation.decoded if source == "decoded" else [r.classes for r in test]
        posts = evaluation.posteriors if source == "decoded" else [None] * len(test)
        for rec, grid, post in zip(test, grids, posts, strict=True):
            geo = GridGeometry(row_pitch_m=rec.row_pitch_m)
            truth = (rec.item_b, rec.item_y, rec.item_class, rec.item_cell)
            found = items_kmeans(grid, geo, size, post, batch_rows=batch_rows)
            scores[source, "k-means"].append(score_items(found, *truth))
            found = items_components(grid, geo, post)
            scores[source, "components"].append(score_items(found, *truth))
    print(
        f"\nItems on the held-out flows, from the decoded grid and (for reference) the true class "
        f"grid; cells per item of paper/plastic/aluminium {size[1]:.1f}/{size[2]:.1f}/"
        f"{size[3]:.1f} expanded cells; k-means in batches of {batch_rows} rows; matched = same "
        "class within 0.25 m"
    )
    print(
        f"{'grid':<9}{'method':<12}{'true':>6}{'found':>7}{'matched':>9}{'median mm':>11}"
        f"{'p95 mm':>9}{'splits':>8}{'merges':>8}{'missed':>8}{'spurious':>9}"
    )
    for (source, name), per_grid in scores.items():
        s = pooled(per_grid)
        print(
            f"{source:<9}{name:<12}{s.n_true:>6}{s.n_found:>7}{s.matched:>9}{s.median_mm:>11.1f}"
            f"{s.p95_mm:>9.1f}{s.splits:>8}{s.merges:>8}{s.missed:>8}{s.spurious:>9}"
        )


@dataclass(frozen=True)
class _Recordings:
    """The evaluation's recordings: labelled training, unlabelled re-estimation, held-out."""

    train: list
    extra: list
    test: list

    @classmethod
    def of(cls, args: argparse.Namespace) -> _Recordings:
        """The seed options resolved (the defaults of `--perception`), refused when the held-out
        seeds were trained on, the options checked, then the recordings made."""
        from sim.errors import InvalidInput
        from sim.flow.catalogue import load_catalogue

        camera = args.perception == "camera"
        for name, truth_default, camera_default in DEFAULT_SEEDS:
            if getattr(args, name) is None:
                setattr(args, name, camera_default if camera else truth_default)
        train_seeds = parse_seed_option(args.train_seeds, "--train-seeds")
        test_seeds = parse_seed_option(args.test_seeds, "--test-seeds")
        extra = args.extra_seeds
        extra_seeds = parse_seed_option(extra, "--extra-seeds") if extra else []
        if set(test_seeds) & (set(train_seeds) | set(extra_seeds)):
            raise InvalidInput("--test-seeds", "seeds not used for training", args.test_seeds)
        check(args)
        if args.save:
            from sim.paths import remove_stale_temporaries

            remove_stale_temporaries(Path(args.save).parent)
        catalogue = load_catalogue()
        return cls(
            _recordings(train_seeds, catalogue, args.perception),
            _recordings(extra_seeds, catalogue, args.perception),
            _recordings(test_seeds, catalogue, args.perception),
        )

    @property
    def refused_rows(self) -> int:
        """Camera frames the pipeline refused (the previous row's codes reused)."""
        return sum(r.refused_rows for r in self.train + self.extra + self.test)


def _print_table(args: argparse.Namespace, recs: _Recordings, ev) -> None:
    """Table 4.1 of the shown model, and its one-step prediction."""
    from perception.hmm.metrics import format_table

    rows = sum(r.classes.shape[0] for r in recs.test)
    print(
        f"Table 4.1 ({'coupled' if args.coupling == 'on' else 'independent'} stripes, "
        f"re-estimated, {args.decode} decoding, {args.perception} codes): train seeds "
        f"{args.train_seeds}, unlabelled {args.extra_seeds or 'none'}, held-out "
        f"{args.test_seeds} ({len(recs.test)} flows, {rows} rows x 5 stripes); thesis in brackets"
    )
    print(format_table(ev.table))
    if args.perception == "camera":
        print(f"(camera frames refused by the pipeline, previous row's codes reused: "
              f"{recs.refused_rows})")  # fmt: skip
    print(
        f"\nOne-step prediction (row t's class before it is seen): accuracy "
        f"{ev.prediction_accuracy:.4f} of all cells, {ev.prediction_accuracy_items:.4f} of "
        f"cells holding an item; its table-4.1 average accuracy {ev.prediction_table[4, 0]:.4f}"
    )


def _print_comparison(results: dict) -> None:
    """Independent and coupled stripes, counted and re-estimated, side by side."""
    print("\nCoupling and re-estimation (held-out):")
    print(
        f"{'stripes':<12}{'model':<14}{'avg acc':>9}{'avg sens':>10}{'avg prec':>10}"
        f"{'cell acc':>10}{'pred acc':>10}{'pred items':>12}{'loglik/row':>12}"
    )
    for (coupled, stage), (_, e) in results.items():
        print(
            f"{'coupled' if coupled else 'independent':<12}{stage:<14}{e.table[4, 0]:>9.4f}"
            f"{e.table[4, 1]:>10.4f}{e.table[4, 3]:>10.4f}{e.cell_accuracy:>10.4f}"
            f"{e.prediction_accuracy:>10.4f}{e.prediction_accuracy_items:>12.4f}"
            f"{e.loglik_per_row:>12.3f}"
        )


def _print_online(models, test: list, coupled: bool) -> None:
    """The shown models filtering row by row, fixed and re-estimated on-line."""
    from perception.hmm.evaluation import evaluate_online
    from perception.hmm.online import OnlineConfig

    print(f"\nOnline, row by row ({'coupled' if coupled else 'independent'}, filtered):")
    for every in (0, 1):
        online = OnlineConfig(window=40, reestimate_every=every, anchor=200.0)
        e = evaluate_online(models, [r.classes for r in test], [r.codes for r in test], online)
        what = "re-estimated every row on 40 rows" if every else "fixed models"
        print(
            f"  {what:<34} avg acc {e.table[4, 0]:.4f}  avg sens {e.table[4, 1]:.4f}  "
            f"cell acc {e.cell_accuracy:.4f}  pred acc {e.prediction_accuracy:.4f}"
        )


def main(args: argparse.Namespace) -> int:
    """Train, evaluate on held-out seeds, print table 4.1 and the comparisons."""
    import time

    from perception.hmm.evaluation import train_and_score
    from perception.hmm.storage import save_models
    from perception.hmm.training import TrainConfig

    t0 = time.perf_counter()
    recs = _Recordings.of(args)
    options = TrainConfig(
        smoothing=args.smoothing, max_iter=args.iterations, tol=args.tol, anchor=args.anchor
    )
    results = train_and_score(
        [r.classes for r in recs.train],
        [r.codes for r in recs.train],
        [r.codes for r in recs.extra],
        [r.classes for r in recs.test],
        [r.codes for r in recs.test],
        options,
        args.decode,
    )
    shown_coupled = args.coupling == "on"
    models, ev = results[shown_coupled, "re-estimated"]
    _print_table(args, recs, ev)
    _print_comparison(results)
    _print_online(models, recs.test, shown_coupled)
    if not args.no_items:
        _items(recs.train, recs.test, ev, args.batch_rows)
    if args.save:
        from sim.sensing.stripe_hmms import item_sizes

        print(f"\nsaved {save_models(args.save, models, item_sizes(recs.train))}")
    print(
        f"\n({time.perf_counter() - t0:.1f} s) reproduce: sortsim hmm-eval --perception "
        f"{args.perception} --train-seeds {args.train_seeds} --extra-seeds '{args.extra_seeds}' "
        f"--test-seeds {args.test_seeds} --iterations {args.iterations} --anchor {args.anchor} "
        f"--coupling {args.coupling} --decode {args.decode} --batch-rows {args.batch_rows}"
    )
    return 0
