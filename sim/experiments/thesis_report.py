"""Our sweep results beside the thesis's tables 4.2-4.6, and figures like its 4.4-4.6.

Each table is printed in the thesis's layout with every cell as `ours (thesis)`; our value is
the mean over the seeds of the sweep's episodes.csv, one block or column per decision manager
(never mixed): `qlearning` is the thesis's algorithm as written (its "Our Method", whose
numbers stand in brackets), `rollout` ours (no thesis counterpart). The thesis's numbers are in
`sim/data/thesis_tables.toml`. `sortsim reproduce` (`sim.experiments.reproduce`) makes the
whole chapter as markdown.
"""

from __future__ import annotations

import tomllib
from collections import defaultdict
from pathlib import Path

from sim.experiments.thesis_figures import figures_for
from sim.paths import DATA_DIR

THESIS_TABLES = DATA_DIR / "thesis_tables.toml"


def thesis_tables() -> dict:
    """The thesis's numbers per table id ('4.2', ...)."""
    with THESIS_TABLES.open("rb") as f:
        return tomllib.load(f)["table"]


def _f(row: dict, key: str) -> float:
    return float(row.get(key) or 0.0)


def group_means(rows: list[dict], keys: tuple[str, ...]) -> dict[tuple, dict[str, float]]:
    """Mean of every numeric column per group of `keys` (speed factors rounded to 3 places)."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for row in rows:
        k = tuple(
            round(float(row[c]), 3) if c == "speed_factor" else row.get(c) or "base" for c in keys
        )
        groups[tuple(int(v) if c == "n_items" else v for c, v in zip(keys, k, strict=True))].append(
            row
        )
    out = {}
    for k, members in groups.items():
        cols: tuple[str, ...] = (
            "accuracy",
            "profit_eur",
            "sim_s",
            "picked",
            "picked_paper",
            "picked_plastic",
        )
        cols += ("picked_aluminium", "entered_paper", "entered_plastic", "entered_aluminium")
        means = {c: sum(_f(r, c) for r in members) / len(members) for c in cols}
        means["n"] = len(members)
        out[k] = means
    return out


def _cell(ours: float | None, theirs: float, fmt: str) -> str:
    left = "-" if ours is None else format(ours, fmt)
    return f"{left} ({format(theirs, fmt)})"


def planners_of(rows: list[dict]) -> list[str]:
    """The rows' decision managers, the thesis's (qlearning, proximity) first."""
    names = {r.get("planner") or "" for r in rows}
    return sorted(names, key=lambda p: (p not in ("qlearning", "proximity"), p))


def table_4_2(rows: list[dict], t: dict) -> str:
    means = group_means(rows, ("planner", "speed_factor", "n_items"))
    lines = [
        t["title"] + " - ours (thesis's Q-learning)",
        "items \\ speed " + "".join(f"{n:>18}" for n in t["items"]),
    ]
    for planner in planners_of(rows):
        lines.append(f"{planner}:")
        for i, f in enumerate(t["speed_factors"]):
            cells = [
                _cell(
                    means.get((planner, round(f, 3), n), {}).get("accuracy"),
                    t["accuracy"][i][j],
                    ".3f",
                )
                for j, n in enumerate(t["items"])
            ]
            lines.append(f"x{f:<13g}" + "".join(f"{c:>18}" for c in cells))
    return "\n".join(lines)


def table_4_3(rows: list[dict], t: dict) -> str:
    means = group_means(rows, ("planner", "variant"))
    head = f"{'':22}" + "".join(
        f"{h:>18}" for h in ("Class2 Picked", "Class3 Picked", "Class4 Picked")
    )
    lines = [t["title"] + " - ours (thesis)"]
    cols = ("picked_paper", "picked_plastic", "picked_aluminium")
    for planner in planners_of(rows):
        lines += [f"{planner}:", head]
        for variant, label, theirs in zip(t["variants"], t["labels"], t["picked"], strict=True):
            m = means.get((planner, variant), {})
            cells = [_cell(m.get(c), theirs[j], ".1f") for j, c in enumerate(cols)]
            lines.append(f"{label:22}" + "".join(f"{c:>18}" for c in cells))
        m = means.get((planner, "normal"), {})
        ent = ("entered_paper", "entered_plastic", "entered_aluminium")
        cells = [_cell(m.get(c), t["entered"][j], ".1f") for j, c in enumerate(ent)]
        lines.append(f"{'Sum of items per class':22}" + "".join(f"{c:>18}" for c in cells))
    return "\n".join(lines)


def table_4_4(rows: list[dict], t: dict) -> str:
    lines = [t["title"] + " - ours (thesis)"]
    for planner in planners_of(rows):
        mine = [r for r in rows if (r.get("planner") or "") == planner]
        lines += [f"{planner}:", f"{'':10}{'Accuracy':>18}{'Time(min)':>18}"]
        for i, row in enumerate(mine):
            theirs_a = t["accuracy"][i] if i < len(t["accuracy"]) else float("nan")
            theirs_t = t["time_min"][i] if i < len(t["time_min"]) else float("nan")
            a = _cell(_f(row, "accuracy"), theirs_a, ".4f")
            m = _cell(_f(row, "sim_s") / 60.0, theirs_t, ".2f")
            lines.append(f"seq. {i + 1:<5}{a:>18}{m:>18}")
        acc = sum(_f(r, "accuracy") for r in mine) / len(mine)
        mins = sum(_f(r, "sim_s") for r in mine) / len(mine) / 60.0
        a = _cell(acc, t["average_accuracy"], ".4f")
        m = _cell(mins, t["average_time_min"], ".2f")
        lines.append(f"{'Average':10}{a:>18}{m:>18}")
    return "\n".join(lines)


def table_4_5(rows: list[dict], t: dict) -> str:
    means = group_means(rows, ("planner", "n_items"))
    planners = planners_of(rows)
    short = {"proximity": "prox", "qlearning": "qlearning", "rollout": "rollout"}
    heads = [f"{m} {short.get(p, p)}" for m in ("Acc", "Time", "Profit") for p in planners]
    lines = [
        t["title"] + " - ours (thesis); qlearning: the thesis's algorithm as written (its "
        "Our Method), rollout: ours",
        f"{'items':>6}" + "".join(f"{h:>17}" for h in heads),
    ]
    for j, n in enumerate(t["items"]):
        cells = []
        for metric, key, fmt in (
            ("accuracy", "accuracy", ".3f"),
            ("time", "sim_s", ".1f"),
            ("profit", "profit_eur", ".2f"),
        ):
            for planner in planners:
                ours = means.get((planner, n), {}).get(key)
                theirs = t.get(f"{metric}_{planner}")
                cell = _cell(ours, theirs[j], fmt) if theirs else _plain(ours, fmt)
                cells.append(cell)
        lines.append(f"{n:>6}" + "".join(f"{c:>17}" for c in cells))
    return "\n".join(lines)


def _plain(ours: float | None, fmt: str) -> str:
    return "-" if ours is None else format(ours, fmt)


FORMATTERS = {
    "4.2": table_4_2,
    "4.3": table_4_3,
    "4.4": table_4_4,
    "4.5": table_4_5,
    "4.6": table_4_5,
}


def format_table(table_id: str | None, rows: list[dict]) -> str:
    """The thesis table `table_id` with our means beside its numbers ('' if unknown)."""
    if table_id not in FORMATTERS:
        return ""
    return "Table " + table_id + ": " + FORMATTERS[table_id](rows, thesis_tables()[table_id])


def save_figures(table_id: str | None, rows: list[dict], out_dir: Path) -> list[Path]:
    """PNG figures like the thesis's 4.4-4.6 (tables 4.5/4.6) or accuracy curves (4.2)."""

    return figures_for(table_id, rows, Path(out_dir), thesis_tables())


def main(argv: list[str] | None = None) -> int:
    """Figures 4.4-4.6 with both speeds: `python -m sim.experiments.thesis_report DIR... --out
    DIR`."""
    import argparse

    from sim.results import outputs

    parser = argparse.ArgumentParser(
        prog="python -m sim.experiments.thesis_report", description=main.__doc__
    )
    parser.add_argument("dirs", nargs="+", type=Path, help="sweep folders with episodes.csv")
    parser.add_argument("--out", type=Path, required=True, help="where to write the PNGs")
    args = parser.parse_args(argv)
    rows = [r for d in args.dirs for r in outputs.read_rows(d / "episodes.csv")]
    for path in figures_for("4.5", rows, args.out, thesis_tables()):
        print(f"figure: {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
