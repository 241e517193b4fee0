"""The camera on busy belts against truth, seed by seed: `docs/perception.md`'s tables 2-5.

Reads the sweeps of `experiments/camera_busy.toml` (one robot, variant `truth` and camera
variants, 100 and 200 items) and `experiments/camera_busy_line.toml` (four robots, variant
`truth` and camera variants) and prints their tables in Markdown: per seed (one robot, a table
per camera variant and item count) or summed over the seeds (the line, a row per variant), the
camera's never-detected and never-visible items, picks and profit against truth's on the same
flows, wrong bins, empty picks, items the confidence rule left on the belt (`left_unsure`) and
each bin's purity (its own material's share of what it holds), pooled over the seeds and on
the lowest seed.

    python -m sim.results.camera_busy_tables runs/camera_busy runs/camera_busy_line
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

from sim.errors import InvalidInput

BINS = ("paper", "plastic", "aluminium")
ONE_ROBOT_HEADER = (
    "| seed | items per metre | never detected | never visible | picked, camera (truth) | "
    "profit EUR, camera (truth) | camera / truth profit | wrong bin | empty picks | "
    "left unsure | purity paper / plastic / aluminium |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|"
)
LINE_HEADER = (
    "| perception | picked (of truth's) | profit EUR (of truth's) | lowest seed: picks / "
    "profit | never detected | never visible | wrong bin | empty picks | left unsure | "
    "purity paper / plastic / aluminium pooled (lowest seed) | thrown |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|"
)


def read_sweep(folder: Path) -> tuple[list[dict], list[dict]]:
    """(episodes.csv rows, picks.csv rows) of a sweep folder; InvalidInput when either is
    missing."""
    out = []
    for name in ("episodes.csv", "picks.csv"):
        path = Path(folder) / name
        if not path.is_file():
            raise InvalidInput("sweep folder", f"a folder with {name} (sortsim sweep)", str(path))
        with open(path, newline="") as f:
            out.append(list(csv.DictReader(f)))
    return out[0], out[1]


def pooled_purity(picks: list[dict], **where: str) -> dict[str, tuple[int, int]]:
    """(right, held) of each bin over the picks that reached a bin and match `where`."""
    rows = [
        r
        for r in picks
        if r["success"] in ("1", "True", "true") and all(r[k] == v for k, v in where.items())
    ]
    return {
        b: (sum(r["bin"] == b == r["true_class"] for r in rows), sum(r["bin"] == b for r in rows))
        for b in BINS
    }


def _shares(purity: dict[str, tuple[int, int]]) -> str:
    return " / ".join(f"{g / t:.3f}" if t else "-" for g, t in purity.values())


def _lowest(picks: list[dict], seeds: list[str], **where: str) -> str:
    """Each bin's lowest purity over the seeds."""
    lows = []
    for b in BINS:
        shares = [g / t for s in seeds for g, t in [pooled_purity(picks, seed=s, **where)[b]] if t]
        lows.append(f"{min(shares):.3f}" if shares else "-")
    return " / ".join(lows)


def camera_variants(episodes: list[dict]) -> list[str]:
    """The sweep's variants other than truth, in the order of its rows."""
    return [v for v in dict.fromkeys(r["variant"] for r in episodes) if v != "truth"]


def one_robot_table(
    episodes: list[dict], picks: list[dict], n_items: str, variant: str = "camera"
) -> str:
    """Table of one robot's camera `variant` against truth at `n_items`, a row per seed and
    their sum."""
    by = {(r["variant"], r["seed"]): r for r in episodes if r["n_items"] == n_items}
    seeds = sorted({s for v, s in by if v == variant}, key=int)
    lines = [ONE_ROBOT_HEADER]
    counted = ("entered", "never_detected", "never_visible", "wrong_bin", "left_unsure")
    total: dict[str, float] = dict.fromkeys(counted, 0)
    total.update(picked=0, truth_picked=0, profit=0.0, truth_profit=0.0, empty=0)
    for s in seeds:
        c, t = by[(variant, s)], by[("truth", s)]
        purity = pooled_purity(picks, variant=variant, n_items=n_items, seed=s)
        ratio = float(c["profit_eur"]) / float(t["profit_eur"])
        lines.append(
            f"| {s} | {float(c['items_per_m']):.1f} | {c['never_detected']} | "
            f"{c['never_visible']} | {c['picked']} ({t['picked']}) | "
            f"{float(c['profit_eur']):.2f} ({float(t['profit_eur']):.2f}) | {ratio:.3f} | "
            f"{c['wrong_bin']} | {c['empty_picks']} | {c['left_unsure']} | {_shares(purity)} |"
        )
        for key in counted:
            total[key] += int(c[key] or 0)
        total["picked"] += int(c["picked"])
        total["truth_picked"] += int(t["picked"])
        total["profit"] += float(c["profit_eur"])
        total["truth_profit"] += float(t["profit_eur"])
        total["empty"] += int(c["empty_picks"])
    n = len(seeds)
    purity = pooled_purity(picks, variant=variant, n_items=n_items)
    missed = total["never_detected"]
    lines.append(
        f"| all {n} | | {missed} of {total['entered']} "
        f"({100 * missed / max(total['entered'], 1):.1f} %) | {total['never_visible']} | "
        f"{total['picked']} ({total['truth_picked']}) | {total['profit'] / n:.2f} "
        f"({total['truth_profit'] / n:.2f}) mean | "
        f"{total['profit'] / total['truth_profit']:.3f} | {total['wrong_bin']} | "
        f"{total['empty']} | {total['left_unsure']} | {_shares(purity)} pooled; lowest seed "
        f"{_lowest(picks, seeds, variant=variant, n_items=n_items)} |"
    )
    return "\n".join(lines)


def line_table(episodes: list[dict], picks: list[dict]) -> str:
    """Table of a line's perceptions against truth, summed over the seeds."""
    by = {(r["variant"], r["seed"]): r for r in episodes}
    seeds = sorted({s for _, s in by}, key=int)
    variants = list(dict.fromkeys(r["variant"] for r in episodes))
    truth = [by[("truth", s)] for s in seeds]
    truth_picked = sum(int(t["picked"]) for t in truth)
    truth_profit = sum(float(t["profit_eur"]) for t in truth)
    lines = [LINE_HEADER]
    n = len(seeds)
    for v in variants:
        rows = [by[(v, s)] for s in seeds]
        picked = sum(int(r["picked"]) for r in rows)
        profit = sum(float(r["profit_eur"]) for r in rows)
        pairs = list(zip(rows, truth, strict=True))
        lowest_picks = min(int(r["picked"]) / int(t["picked"]) for r, t in pairs)
        lowest_profit = min(float(r["profit_eur"]) / float(t["profit_eur"]) for r, t in pairs)
        never_visible = "-" if v == "truth" else sum(int(r["never_visible"] or 0) for r in rows)
        lines.append(
            f"| {v} | {picked / n:.1f} ({picked / truth_picked:.3f}) | {profit / n:.2f} "
            f"({profit / truth_profit:.3f}) | {lowest_picks:.3f} / {lowest_profit:.3f} | "
            f"{sum(int(r['never_detected']) for r in rows)} of "
            f"{sum(int(r['entered']) for r in rows)} | {never_visible} | "
            f"{sum(int(r['wrong_bin']) for r in rows)} | "
            f"{sum(int(r['empty_picks']) for r in rows)} | "
            f"{sum(int(r['left_unsure'] or 0) for r in rows)} | "
            f"{_shares(pooled_purity(picks, variant=v))} ({_lowest(picks, seeds, variant=v)}) | "
            f"{sum(int(r['thrown_off']) for r in rows)} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Print the tables of the one-robot sweep and the line's sweep."""
    parser = argparse.ArgumentParser(prog="python -m sim.results.camera_busy_tables")
    parser.add_argument("one_robot", type=Path, help="the sweep of experiments/camera_busy.toml")
    parser.add_argument("line", type=Path, help="the sweep of experiments/camera_busy_line.toml")
    args = parser.parse_args(argv)
    try:
        one = read_sweep(args.one_robot)
        line = read_sweep(args.line)
    except InvalidInput as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for variant in camera_variants(one[0]):
        for n_items in sorted({r["n_items"] for r in one[0]}, key=int):
            table = one_robot_table(*one, n_items, variant)
            print(f"One robot, {n_items} items in 90 s, {variant}:\n\n{table}\n")
    print(f"A line:\n\n{line_table(*line)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
