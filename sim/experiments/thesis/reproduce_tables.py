"""The decision tables of `sortsim reproduce` (thesis tables 4.2-4.6) and the +13 % finding.

Each function takes the run (`sim.experiments.thesis.reproduce_run.Run`), reads the rows of its
sweeps and returns a `Block`: markdown tables with our means over the seeds beside the
thesis's numbers (`sim/data/thesis_tables.toml`), and a reading computed from the same numbers.
The decision managers have their own columns: `qlearning` is the thesis's algorithm as written
(the thesis's "Our Method"), `rollout` is ours (no counterpart in the thesis), `proximity` the
thesis's comparison picker; tables 4.5 and 4.6 and the finding add `random`, the thesis's "random
picker" (a uniform draw among the items the cup can meet now), from sweeps of its own
(`<sweep>_random`: the same flows, belt and regime).
"""

from __future__ import annotations

import statistics
from collections import defaultdict
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

from perception.codes import THESIS_VALUES_EUR
from sim.experiments.thesis.reproduce_run import Block
from sim.experiments.thesis.thesis_report import thesis_tables

if TYPE_CHECKING:
    from sim.experiments.thesis.reproduce_run import Run


PLANNERS = ("qlearning", "rollout", "proximity")
"""The decision managers of the tables, in their columns' order."""
HEADS = {
    "qlearning": "qlearning (thesis's algorithm)",
    "rollout": "rollout (ours)",
    "proximity": "proximity",
    "random": "random (thesis's random picker)",
    "lookahead": "lookahead (ours)",
}
DECISION_PLANNERS = (*PLANNERS, "random")
"""The decision managers of tables 4.5 and 4.6, in their columns' order: the tables' three and
the thesis's "random picker" (a sweep of its own, `<sweep>_random`)."""
COMPARISONS = (
    ("qlearning", "proximity"),
    ("rollout", "proximity"),
    ("random", "proximity"),
    ("qlearning", "random"),
)
"""The profit differences tables 4.5 and 4.6 give per dataset (planner, against)."""
MATERIALS = ("paper", "plastic", "aluminium")
KEY_NOTE = (
    "Each cell: qlearning / rollout / proximity / random, ours (the thesis's). `qlearning` is "
    'the thesis\'s Q-learning as written (its "Our Method"), `rollout` ours (no thesis '
    "counterpart), `proximity` the thesis's comparison picker, `random` the thesis's \"random "
    'picker" (a uniform draw among the items the cup can meet now; the thesis gives no '
    "numbers of it); means over the seeds."
)


def _f(row: dict, key: str) -> float:
    value = row.get(key)
    return float(value) if value not in (None, "") else 0.0


def groups(rows: list[dict], *keys: str) -> dict[tuple, list[dict]]:
    """Rows by the values of `keys` (speed factors rounded to 3 places, items as ints)."""
    out: dict[tuple, list[dict]] = defaultdict(list)
    for row in rows:
        key: list[Any] = []
        for k in keys:
            if k == "speed_factor":
                key.append(round(float(row[k]), 3))
            elif k == "n_items":
                key.append(int(row[k]))
            else:
                key.append(row.get(k) or "base")
        out[tuple(key)].append(row)
    return out


def mean(rows: list[dict], key: str) -> float | None:
    """Mean of column `key` (None without rows)."""
    return mean_of(rows, key) if rows else None


def mean_of(rows: list[dict], key: str) -> float:
    """Mean of column `key` of `rows` (at least one)."""
    return statistics.fmean(_f(r, key) for r in rows)


def class_accuracy(rows: list[dict], material: str) -> float | None:
    """Picked over entered of one material, pooled over the rows."""
    entered = sum(_f(r, f"entered_{material}") for r in rows)
    return sum(_f(r, f"picked_{material}") for r in rows) / entered if entered else None


def cell(ours: float | None, theirs: float | None, fmt: str) -> str:
    """'ours (theirs)', '-' for a missing value of ours."""
    left = "-" if ours is None else format(ours, fmt)
    return left if theirs is None else f"{left} ({format(theirs, fmt)})"


def pct(a: float | None, b: float | None) -> float | None:
    """100 (a - b) / b, None when either is missing or b is 0."""
    return None if a is None or not b else 100.0 * (a - b) / b


def thesis_gains(t: dict, ours: str, against: str) -> list[float]:
    """`pct` of the thesis's column `ours` against `against`, item count by item count (its
    columns have no gaps and no zeros, so no None)."""
    return cast(list[float], [pct(a, b) for a, b in zip(t[ours], t[against], strict=True)])


def signed(value: float | None, digits: int = 1) -> str:
    return "-" if value is None else f"{value:+.{digits}f} %"


def at(t: dict, key: str, n: int, axis: str = "items") -> float | None:
    """The thesis's value of column `key` at item count `n` (None where it has none)."""
    return t[key][t[axis].index(n)] if n in t[axis] else None


def item_counts(t: dict, by: dict) -> list[int]:
    """The thesis's item counts and any other our rows hold, in order."""
    return sorted(set(t["items"]) | {k[0] for k in by})


THESIS_SEEDS = {"4.2": 10, "4.3": 10, "4.4": 4}
"""The flows a grid point the thesis ran for tables 4.2-4.4 (its text: 10, 10 and 4)."""


def seeds_said(run: Run, sweep: str, table: str) -> str:
    """`Run.seeds_text` of `sweep` and the thesis's count for `table`, for a block's first line."""
    return f"{run.seeds_text(sweep)}; the thesis: {THESIS_SEEDS[table]}"


def table_4_2(run: Run) -> Block:
    """Table 4.2: accuracy SP/SI per belt speed and items, the three decision managers."""
    return _table_4_2(run, "reproduce_4_2", "table_4_2", "physical cycle")


def table_4_2_paused(run: Run) -> Block:
    """Table 4.2 with the thesis's pauses."""
    return _table_4_2(run, "reproduce_4_2_paused", "table_4_2_paused", "the thesis's pauses")


def _table_4_2(run: Run, sweep: str, piece: str, regime: str) -> Block:
    t = thesis_tables()["4.2"]
    by = groups(run.rows(sweep), "speed_factor", "n_items", "planner")
    items = sorted(set(t["items"]) | {k[1] for k in by})
    factors = sorted(set(t["speed_factors"]) | {k[0] for k in by})
    head = "| belt | " + " | ".join(f"{n} items" for n in items) + " |"
    lines = [head, "|---|" + "---|" * len(items)]
    for factor in factors:
        cells = []
        for n in items:
            theirs = None
            if factor in t["speed_factors"] and n in t["items"]:
                theirs = t["accuracy"][t["speed_factors"].index(factor)][t["items"].index(n)]
            ours = [mean(by.get((round(factor, 3), n, p), []), "accuracy") for p in PLANNERS]
            text = " / ".join("-" if v is None else f"{v:.3f}" for v in ours)
            cells.append(text + ("" if theirs is None else f" ({theirs:.3f})"))
        lines.append(f"| x{factor:g} | " + " | ".join(cells) + " |")
    q_accuracy = [mean_of(v, "accuracy") for (_, _, p), v in by.items() if p == "qlearning"]
    why = (
        " (our flows keep the items per second at every speed, and the physical cycle, about "
        "0.65 s, keeps up with 0.6-1.7 items/s)"
        if regime == "physical cycle"
        else f" ({regime})"
    )
    reading = (
        f"Reading: the thesis's robot fell from 0.90 to 0.53 over these grids; qlearning here "
        f"picks {min(q_accuracy):.3f}-{max(q_accuracy):.3f} of the items{why}."
        if q_accuracy
        else ""
    )
    what = seeds_said(run, sweep, "4.2") + f", 90 s flows, {regime}"
    note = (
        "Each cell: accuracy SP/SI of qlearning / rollout / proximity (the thesis's Q-learning); "
        "`qlearning` is the thesis's algorithm as written, `rollout` ours."
    )
    return Block("\n".join([run.label(piece, what), "", note, "", *lines, "", reading]))


def _table_4_3(run: Run, sweep: str, piece: str, regime: str) -> Block:
    t = thesis_tables()["4.3"]
    by = groups(run.rows(sweep), "variant", "planner")
    lines = [
        "| values | thesis: paper / plastic / aluminium picked | "
        + " | ".join(HEADS[p] for p in PLANNERS)
        + " |",
        "|---|---|" + "---|" * len(PLANNERS),
    ]
    labels = ("normal values", "paper +150", "plastic +150", "aluminium +150")
    shares = {}
    for variant, label, theirs in zip(t["variants"], labels, t["picked"], strict=True):
        cells = []
        for p in PLANNERS:
            rows = by.get((variant, p), [])
            picked = [mean_of(rows, f"picked_{m}") for m in MATERIALS] if rows else []
            cells.append("-" if not rows else " / ".join(f"{v:.1f}" for v in picked))
            if rows:
                shares[variant, p] = [v / max(sum(picked), 1e-9) for v in picked]
        thesis = " / ".join(str(v) for v in theirs)
        lines.append(f"| {label} | {thesis} | " + " | ".join(cells) + " |")
    normal = [r for (v, _), rows in by.items() if v == "normal" for r in rows]
    entered = (
        " / ".join(f"{mean(normal, f'entered_{m}'):.1f}" for m in MATERIALS) if normal else "-"
    )
    lines.append(
        f"| items per class | {' / '.join(str(v) for v in t['entered'])} | {entered} | | |"
    )
    moves = []
    for p in PLANNERS:
        base = shares.get(("normal", p))
        if base is None:
            continue
        ups = []
        for k, variant in enumerate(t["variants"][1:]):
            boosted = shares.get((variant, p))
            if boosted is not None:
                ups.append(f"{MATERIALS[k]} {base[k]:.2f} -> {boosted[k]:.2f}")
        moves.append(f"{p}: " + ", ".join(ups))
    reading = (
        "Reading: each class's share of the picks, normal values -> that class worth 150 EUR "
        "more (the thesis: paper 0.29 -> 0.35, plastic 0.32 -> 0.40, aluminium 0.39 -> 0.41): "
        + "; ".join(moves)
        + "."
    )
    what = seeds_said(run, sweep, "4.3") + f", 118 items over 90 s at x1, {regime}"
    return Block("\n".join([run.label(piece, what), "", *lines, "", reading]))


def table_4_3(run: Run) -> Block:
    """Table 4.3: picks per class, each class's value raised in turn; physical cycle."""
    return _table_4_3(run, "reproduce_4_3", "table_4_3", "physical cycle")


def table_4_3_paused(run: Run) -> Block:
    """Table 4.3 with the thesis's pauses (its regime: the robot cannot pick everything)."""
    return _table_4_3(run, "reproduce_4_3_paused", "table_4_3_paused", "the thesis's pauses")


def table_4_4(run: Run) -> Block:
    """Table 4.4: accuracy and time of each long flow, the three decision managers."""
    return _table_4_4(run, "reproduce_4_4", "table_4_4", "physical cycle")


def table_4_4_paused(run: Run) -> Block:
    """Table 4.4 with the thesis's pauses."""
    return _table_4_4(run, "reproduce_4_4_paused", "table_4_4_paused", "the thesis's pauses")


def _table_4_4(run: Run, sweep: str, piece: str, regime: str) -> Block:
    t = thesis_tables()["4.4"]
    by = groups(run.rows(sweep), "planner", "seed")
    seeds = sorted({int(s) for (_, s) in by}, key=int)
    lines = [
        "| flow | thesis accuracy | "
        + " | ".join(f"{HEADS[p]} accuracy" for p in PLANNERS)
        + " | thesis time [min] | time [min] (qlearning) |",
        "|---|---|" + "---|" * len(PLANNERS) + "---|---|",
    ]
    for i, seed in enumerate(seeds):
        cells = [cell(mean(by.get((p, str(seed)), []), "accuracy"), None, ".3f") for p in PLANNERS]
        theirs = (t["accuracy"][i], t["time_min"][i]) if i < len(t["accuracy"]) else (None, None)
        minutes = mean(by.get(("qlearning", str(seed)), []), "sim_s")
        lines.append(
            f"| seed {seed} | {cell(theirs[0], None, '.3f')} | "
            + " | ".join(cells)
            + f" | {cell(theirs[1], None, '.2f')} | {cell(minutes and minutes / 60, None, '.2f')} |"
        )
    avg = [mean([r for (q, _), v in by.items() if q == p for r in v], "accuracy") for p in PLANNERS]
    q_rows = [r for (q, _), v in by.items() if q == "qlearning" for r in v]
    q_min = mean(q_rows, "sim_s")
    lines.append(
        f"| mean | {t['average_accuracy']:.3f} | "
        + " | ".join(cell(a, None, ".3f") for a in avg)
        + f" | {t['average_time_min']:.2f} | {cell(q_min and q_min / 60, None, '.2f')} |"
    )
    what = seeds_said(run, sweep, "4.4") + f", 3000 items over 25 min at x1, {regime}"
    rates = {
        p: statistics.fmean(_f(r, "picked") / max(_f(r, "sim_s"), 1e-9) for r in rows)
        for (p,), rows in groups(run.rows(sweep), "planner").items()
    }
    per_s = ", ".join(f"{p} {rates[p]:.2f}" for p in PLANNERS if p in rates)
    reading = (
        "Reading: two items a second for 25 minutes; the thesis's robot picked 0.57 of them. "
        f"Ours is held by its cycle: items picked a second, {per_s}."
    )
    return Block("\n".join([run.label(piece, what), "", *lines, "", reading]))


def _decision_rows(run: Run, sweep: str) -> list[dict]:
    """The rows of a table 4.5/4.6 sweep and of its random picker's (`<sweep>_random`)."""
    return run.rows(sweep) + run.rows(f"{sweep}_random")


def _decision_cells(
    by: dict, n: int, t: dict, planners: tuple[str, ...] = DECISION_PLANNERS
) -> list[str]:
    """Accuracy, time and profit of each of `planners` at `n` items, ours (the thesis's)."""
    metrics = (
        ("accuracy", "accuracy", ".3f"),
        ("time", "sim_s", ".1f"),
        ("profit", "profit_eur", ".2f"),
    )
    cells = []
    for metric, key, fmt in metrics:
        parts = []
        for p in planners:
            theirs = at(t, f"{metric}_{p}", n) if p in ("qlearning", "proximity") else None
            parts.append(cell(mean(by.get((n, p), []), key), theirs, fmt))
        cells.append(" / ".join(parts))
    return cells


def _gain_reading(gains: dict[tuple[str, str], list[float]], thesis_all: list[float]) -> str:
    """The reading under a table 4.5/4.6: each comparison's mean and range over the datasets."""
    parts = []
    for (p, against), g in gains.items():
        if g:
            parts.append(
                f"{p} earns {statistics.fmean(g):+.1f} % against {against} on the mean "
                f"({min(g):+.1f} to {max(g):+.1f} %, more on "
                f"{sum(x > 0.05 for x in g)} of {len(g)} datasets)"
            )
    return (
        "Reading: " + "; ".join(parts) + f"; the thesis (its Q-learning against its proximity "
        f"picker): {statistics.fmean(thesis_all):+.1f} % "
        f"({min(thesis_all):+.1f} to {max(thesis_all):+.1f} %)."
    )


@dataclass(frozen=True)
class DecisionColumns:
    """The planners of a table 4.5/4.6 block, its profit comparisons (planner, against), the
    sweeps beside its own that hold its rows ({sweep}: the sweep's name) and its note."""

    planners: tuple[str, ...] = DECISION_PLANNERS
    comparisons: tuple[tuple[str, str], ...] = COMPARISONS
    extra_sweeps: tuple[str, ...] = ("{sweep}_random",)
    note: str = KEY_NOTE


def decision_table(
    run: Run,
    sweep: str,
    table: str,
    piece: str,
    regime: str,
    columns: DecisionColumns = DecisionColumns(),
) -> Block:
    t = thesis_tables()[table]
    sweeps = (sweep, *(s.format(sweep=sweep) for s in columns.extra_sweeps))
    by = groups([r for s in sweeps for r in run.rows(s)], "n_items", "planner")
    order = " / ".join(HEADS[p] for p in columns.planners)
    heads = [
        f"{p} - {a}" + (" profit (thesis)" if (p, a) == ("qlearning", "proximity") else "")
        for p, a in columns.comparisons
    ]
    lines = [
        f"| items | accuracy: {order} | time [s] | profit [EUR] | " + " | ".join(heads) + " |",
        "|---|---|---|---|" + "---|" * len(heads),
    ]
    gains: dict[tuple[str, str], list[float]] = {c: [] for c in columns.comparisons}
    for n in item_counts(t, by):
        thesis_gain = pct(at(t, "profit_qlearning", n), at(t, "profit_proximity", n))
        diffs = []
        for p, against in columns.comparisons:
            g = pct(
                mean(by.get((n, p), []), "profit_eur"), mean(by.get((n, against), []), "profit_eur")
            )
            if g is not None:
                gains[p, against].append(g)
            thesis = (p, against) == ("qlearning", "proximity")
            diffs.append(signed(g) + (f" ({signed(thesis_gain)})" if thesis else ""))
        cells = _decision_cells(by, n, t, columns.planners)
        lines.append(f"| {n} | " + " | ".join(cells) + " | " + " | ".join(diffs) + " |")
    thesis_all = thesis_gains(t, "profit_qlearning", "profit_proximity")
    reading = _gain_reading(gains, thesis_all)
    what = run.seeds_text(*sweeps) + f", belt x{t['speed_factor']:g}, {regime}"
    return Block("\n".join([run.label(piece, what), "", columns.note, "", *lines, "", reading]))


def table_4_5(run: Run) -> Block:
    """Table 4.5 (x1), the robot's physical cycle."""
    return decision_table(run, "reproduce_4_5", "4.5", "table_4_5", "physical cycle")


def table_4_6(run: Run) -> Block:
    """Table 4.6 (x1.2), the robot's physical cycle."""
    return decision_table(run, "reproduce_4_6", "4.6", "table_4_6", "physical cycle")


def table_4_5_paused(run: Run) -> Block:
    """Table 4.5 (x1) with the thesis's pauses."""
    return decision_table(
        run, "reproduce_4_5_paused", "4.5", "table_4_5_paused", "the thesis's pauses"
    )


def table_4_6_paused(run: Run) -> Block:
    """Table 4.6 (x1.2) with the thesis's pauses."""
    return decision_table(
        run, "reproduce_4_6_paused", "4.6", "table_4_6_paused", "the thesis's pauses"
    )


PERCEPTIONS = (
    ("truth", "truth"),
    ("camera_hmm", "camera, stripe HMMs (thesis's path)"),
    ("camera_fused", "camera, fused classifier"),
)


def _coupling_text(sweep) -> str:
    """How each camera variant's stripe HMMs ran, read from the episodes' configs:
    "the HMMs' stripes coupled for camera, stripe HMMs (thesis's path); independent for ..."."""
    labels = dict(PERCEPTIONS)
    coupled = {spec.variant: spec.config.hmm.coupled for spec in sweep.episodes}
    parts = [
        f"{'coupled' if on else 'independent'} for {labels.get(v, v)}" for v, on in coupled.items()
    ]
    return "the HMMs' stripes " + "; ".join(parts)


def _camera_table(run: Run, table: str, piece: str) -> Block:
    t = thesis_tables()[table]
    sweep = "reproduce_4_5" if table == "4.5" else "reproduce_4_6"
    truth = groups(run.rows(sweep), "n_items", "planner")
    camera = groups(run.rows(sweep + "_camera"), "variant", "n_items", "planner")
    lines = [
        "| items | "
        + " | ".join(label for _, label in PERCEPTIONS)
        + " | thesis: proximity / its Q-learning |",
        "|---|" + "---|" * len(PERCEPTIONS) + "---|",
    ]
    ratios: dict[str, list[float]] = defaultdict(list)
    accuracy: dict[str, list[float]] = defaultdict(list)
    for n in item_counts(t, truth):
        cells = []
        for variant, _ in PERCEPTIONS:
            profits = []
            for p in PLANNERS:
                rows = (
                    truth.get((n, p), []) if variant == "truth" else camera.get((variant, n, p), [])
                )
                profit = mean(rows, "profit_eur")
                profits.append("-" if profit is None else f"{profit:.2f}")
                if rows:
                    accuracy[variant].append(mean_of(rows, "accuracy"))
                base = mean(truth.get((n, p), []), "profit_eur")
                if variant != "truth" and profit is not None and base:
                    ratios[variant].append(profit / base)
            cells.append(" / ".join(profits))
        thesis = (
            f"{at(t, 'profit_proximity', n):.2f} / {at(t, 'profit_qlearning', n):.2f}"
            if n in t["items"]
            else ""
        )
        lines.append(f"| {n} | " + " | ".join(cells) + f" | {thesis} |")
    parts = [
        f"{label}: {statistics.fmean(ratios[v]):.3f} of truth's profit "
        f"({min(ratios[v]):.3f}-{max(ratios[v]):.3f})"
        for v, label in PERCEPTIONS[1:]
        if ratios[v]
    ]
    acc = [
        f"{label} {statistics.fmean(accuracy[v]):.3f}" for v, label in PERCEPTIONS if accuracy[v]
    ]
    reading = (
        "Reading, over planners and datasets: "
        + "; ".join(parts)
        + ". Mean accuracy: "
        + ", ".join(acc)
        + "."
        if parts
        else ""
    )
    what = (
        run.seeds_text(sweep, sweep + "_camera")
        + f", belt x{t['speed_factor']:g}, physical cycle, varied world, stereo depth noise; "
        + _coupling_text(run.sweep(sweep + "_camera"))
    )
    note = (
        "Each cell: mean profit [EUR] of qlearning / rollout / proximity (`qlearning` the "
        "thesis's algorithm as written, `rollout` ours)."
    )
    return Block("\n".join([run.label(piece, what), "", note, "", *lines, "", reading]))


def table_4_5_camera(run: Run) -> Block:
    """Table 4.5's datasets: truth, camera with the stripe HMMs, camera fused."""
    return _camera_table(run, "4.5", "table_4_5_camera")


def table_4_6_camera(run: Run) -> Block:
    """Table 4.6's datasets: truth, camera with the stripe HMMs, camera fused."""
    return _camera_table(run, "4.6", "table_4_6_camera")


REGIMES = (
    ("physical cycle", "reproduce_4_5", "reproduce_4_6", None),
    ("the thesis's pauses", "reproduce_4_5_paused", "reproduce_4_6_paused", None),
    ("camera, stripe HMMs", "reproduce_4_5_camera", "reproduce_4_6_camera", "camera_hmm"),
    ("camera, fused", "reproduce_4_5_camera", "reproduce_4_6_camera", "camera_fused"),
)
RANDOM_REGIMES = REGIMES[:2]
"""The regimes the random picker ran in (truth perception; its sweeps `<sweep>_random`)."""


def random_sweeps() -> tuple[str, ...]:
    """The random picker's sweeps, one per regime of `RANDOM_REGIMES` and belt speed."""
    return tuple(f"{s}_random" for r in RANDOM_REGIMES for s in r[1:3])


def _split(rows_q: list[dict], rows_p: list[dict]) -> tuple[float, float, float, float] | None:
    """(profit, picks, value per pick, aluminium accuracy in points) of Q against proximity."""
    if not rows_q or not rows_p:
        return None
    profit = pct(mean(rows_q, "profit_eur"), mean(rows_p, "profit_eur"))
    picks = pct(mean(rows_q, "picked"), mean(rows_p, "picked"))
    vq = mean_of(rows_q, "profit_eur") / max(mean_of(rows_q, "picked"), 1e-9)
    vp = mean_of(rows_p, "profit_eur") / max(mean_of(rows_p, "picked"), 1e-9)
    al = 100.0 * (
        (class_accuracy(rows_q, "aluminium") or 0) - (class_accuracy(rows_p, "aluminium") or 0)
    )
    per_pick = pct(vq, vp)
    assert profit is not None and picks is not None and per_pick is not None  # proximity earns
    return profit, picks, per_pick, al


def _regime_cells(
    by: dict,
    items: list[int],
    planners: tuple[str, ...] = ("qlearning", "rollout"),
    against: str = "proximity",
    fields: int = 4,
) -> tuple[list[str], dict[int, float]]:
    """The finding's cells of one regime and speed: for each of `planners` against `against`,
    the first `fields` of profit (with its range over the datasets), picks, value per pick and
    aluminium [points]; and the first planner's profit gain per item count."""
    cells, gains = [], {}
    for planner in planners:
        got = []
        for n in items:
            s = _split(by.get((n, planner), []), by.get((n, against), []))
            if s is not None:
                got.append(s)
                if planner == planners[0]:
                    gains[n] = s[0]
        if not got:
            cells += ["-"] * fields
            continue
        avg = [statistics.fmean(s[i] for s in got) for i in range(4)]
        span = f" ({min(s[0] for s in got):+.1f} to {max(s[0] for s in got):+.1f})"
        row = [signed(avg[0]) + span, signed(avg[1]), signed(avg[2]), f"{avg[3]:+.1f}"]
        cells += row[:fields]
    return cells, gains


def _thesis_split(t: dict) -> str:
    """The thesis's row of the finding: its profit gain split by its accuracy gain."""
    prof = thesis_gains(t, "profit_qlearning", "profit_proximity")
    acc = thesis_gains(t, "accuracy_qlearning", "accuracy_proximity")
    vpp = [100.0 * ((1 + p / 100) / (1 + a / 100) - 1) for p, a in zip(prof, acc, strict=True)]
    return (
        f"| the thesis | x{t['speed_factor']:g} | {signed(statistics.fmean(prof))} "
        f"({min(prof):+.1f} to {max(prof):+.1f}) | {signed(statistics.fmean(acc))} | "
        f"{signed(statistics.fmean(vpp))} | | | | | |"
    )


def _per_items(per_items: dict, tables: dict) -> list[str]:
    """qlearning's profit gain per dataset in the truth regimes, beside the thesis's."""
    items = sorted({n for v in per_items.values() for n in v} | set(tables["4.5"]["items"]))
    cols = [k for k in per_items if k[0] in ("physical cycle", "the thesis's pauses")]
    sub = [
        "| items | "
        + " | ".join(f"{r}, x{tables[t]['speed_factor']:g}" for r, t in cols)
        + " | thesis x1 | thesis x1.2 |",
        "|---|" + "---|" * (len(cols) + 2),
    ]
    for n in items:
        ours = [signed(per_items[k].get(n)) for k in cols]
        theirs = [
            signed(pct(at(tables[t], "profit_qlearning", n), at(tables[t], "profit_proximity", n)))
            for t in ("4.5", "4.6")
        ]
        sub.append(f"| {n} | " + " | ".join(ours + theirs) + " |")
    return sub


def _against_random(run: Run, tables: dict) -> list[str]:
    """The finding's table against the thesis's random picker: qlearning, rollout and
    proximity each against random, per truth regime and speed."""
    planners = ("qlearning", "rollout", "proximity")
    lines = [
        "| regime | belt | "
        + " | ".join(f"{p}: profit | picks | value per pick" for p in planners)
        + " |",
        "|---|---|" + "---|" * (3 * len(planners)),
    ]
    for regime, s45, s46, _ in RANDOM_REGIMES:
        for sweep, table in ((s45, "4.5"), (s46, "4.6")):
            by = groups(_decision_rows(run, sweep), "n_items", "planner")
            cells, gains = _regime_cells(by, item_counts(tables[table], by), planners, "random", 3)
            if gains:
                speed = tables[table]["speed_factor"]
                lines.append(f"| {regime} | x{speed:g} | " + " | ".join(cells) + " |")
    return lines


def finding_13(run: Run) -> Block:
    """The +13 %: qlearning (and rollout) against proximity by regime, speed and density, the
    profit split into items picked and value per pick (profit = picks x value per pick); and
    each against the thesis's random picker."""
    tables = thesis_tables()
    lines = [
        "| regime | belt | qlearning: profit | picks | value per pick | aluminium [points] | "
        "rollout: profit | picks | value per pick | aluminium [points] |",
        "|---|---|" + "---|" * 8,
    ]
    per_items: dict[tuple[str, str], dict[int, float]] = {}
    for regime, s45, s46, variant in REGIMES:
        for sweep, table in ((s45, "4.5"), (s46, "4.6")):
            rows = run.rows(sweep)
            if variant is not None:
                rows = [r for r in rows if r.get("variant") == variant]
            by = groups(rows, "n_items", "planner")
            cells, gains = _regime_cells(by, item_counts(tables[table], by))
            if not gains:
                continue
            per_items[regime, table] = gains
            speed = tables[table]["speed_factor"]
            lines.append(f"| {regime} | x{speed:g} | " + " | ".join(cells) + " |")
    lines += [_thesis_split(tables[t]) for t in ("4.5", "4.6")]
    ceiling = _value_ceiling(run.rows("reproduce_4_5"))
    what = run.seeds_text(*{s for r in REGIMES for s in r[1:3]}, *random_sweeps())
    text = [
        run.label("finding_13", what),
        "",
        "qlearning (the thesis's algorithm as written) and rollout (ours) against proximity: "
        "profit, mean over the datasets (80-400 items) and (range), split as profit = picks x "
        "value per pick, and the accuracy of aluminium (the most valuable class) in points; "
        "the thesis's split from its accuracy and profit columns.",
        "",
        *lines,
        "",
        "qlearning - proximity profit per dataset:",
        "",
        *_per_items(per_items, tables),
        "",
        'Against the thesis\'s "random picker" (a uniform draw among the items the cup can '
        "meet now; truth perception): qlearning, rollout and proximity each against random, "
        "profit (range), picks and value per pick, means over the datasets.",
        "",
        *_against_random(run, tables),
        "",
        f"The most a pick order can add by value alone at equal picks: every pick aluminium, "
        f"{ceiling:+.1f} % over the mean item's value of these flows."
        if ceiling is not None
        else "",
    ]
    return Block("\n".join(text))


def _value_ceiling(rows: list[dict]) -> float | None:
    """100 (0.27 / mean value of the items that entered - 1): value per pick at most."""
    values = dict(zip(MATERIALS, THESIS_VALUES_EUR, strict=True))
    entered = {m: sum(_f(r, f"entered_{m}") for r in rows) for m in MATERIALS}
    total = sum(entered.values())
    if not total:
        return None
    avg = sum(values[m] * entered[m] for m in MATERIALS) / total
    return 100.0 * (max(values.values()) / avg - 1.0)
