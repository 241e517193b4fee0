"""Decision managers side by side over sweep results: mean profit per dataset and planner, and
whether one planner earns more than each other in every dataset (and on how many seeds).

    python -m sim.experiments.planner_table runs/dense_4_5 runs/table_4_5 [--lead lookahead]

Reads each folder's `episodes.csv`; a dataset is (speed factor, items); an episode met in two
folders (same dataset, planner and seed) must agree on its profit, and is counted once.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
from collections import defaultdict
from pathlib import Path

from sim.errors import InvalidInput


def read_episodes(folders: list[Path]) -> dict[tuple, dict]:
    """{(speed_factor, items, planner, seed): row} over the folders' episodes.csv."""
    rows: dict[tuple, dict] = {}
    for folder in folders:
        path = Path(folder) / "episodes.csv"
        if not path.is_file():
            raise InvalidInput("folder", "a sweep or run folder holding episodes.csv", str(folder))
        with path.open(newline="") as f:
            for row in csv.DictReader(f):
                key = (
                    float(row["speed_factor"]),
                    int(row["n_items"]),
                    row["planner"],
                    int(row["seed"]),
                )
                old = rows.get(key)
                if old is not None and old["profit_eur"] != row["profit_eur"]:
                    raise InvalidInput(
                        "episodes.csv", "one profit per episode", f"{key}: two profits"
                    )
                rows[key] = row
    return rows


def table(rows: dict[tuple, dict], lead: str) -> str:
    """Markdown: mean profit [EUR] and picked per dataset and planner, then `lead`'s margin over
    each other planner (mean, and seeds where it earns more / as much / less)."""
    by_set: dict[tuple, dict[str, dict[int, dict]]] = defaultdict(lambda: defaultdict(dict))
    for (speed, items, planner, seed), row in rows.items():
        by_set[(speed, items)][planner][seed] = row
    planners = sorted({k[2] for k in rows}, key=lambda p: (p != lead, p))
    lines = [
        "| belt | items | " + " | ".join(planners) + " |",
        "|---|---|" + "---|" * len(planners),
    ]
    margins = []
    for (speed, items), runs in sorted(by_set.items()):
        cells = []
        for p in planners:
            seeds = runs.get(p, {})
            if not seeds:
                cells.append("-")
                continue
            profit = statistics.fmean(float(r["profit_eur"]) for r in seeds.values())
            picked = statistics.fmean(float(r["picked"]) for r in seeds.values())
            cells.append(f"{profit:.2f} ({picked:.1f}, n={len(seeds)})")
        lines.append(f"| x{speed:g} | {items} | " + " | ".join(cells) + " |")
        mine = runs.get(lead, {})
        for p in planners:
            if p == lead or not runs.get(p):
                continue
            common = sorted(set(mine) & set(runs[p]))
            if not common:
                continue
            diffs = [float(mine[s]["profit_eur"]) - float(runs[p][s]["profit_eur"]) for s in common]
            wins = sum(d > 1e-9 for d in diffs)
            ties = sum(abs(d) <= 1e-9 for d in diffs)
            margins.append((speed, items, p, statistics.fmean(diffs), wins, ties, len(diffs)))
    lines += [
        "",
        f"`{lead}` minus each planner, mean profit [EUR] (seeds more / equal / less):",
        "",
        "| belt | items | planner | margin | seeds |",
        "|---|---|---|---|---|",
    ]
    for speed, items, p, mean, wins, ties, n in margins:
        lines.append(
            f"| x{speed:g} | {items} | {p} | {mean:+.2f} | {wins} / {ties} / {n - wins - ties} |"
        )
    ahead = bool(margins) and all(m[3] > 0 for m in margins)
    lines += ["", f"`{lead}` earns more on the mean in every dataset than every planner: {ahead}"]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim.experiments.planner_table")
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--lead", default="lookahead", help="the planner compared with the rest")
    args = parser.parse_args(argv)
    try:
        rows = read_episodes(args.folders)
    except InvalidInput as exc:
        print(f"planner_table: {exc}", file=sys.stderr)
        return 2
    print(table(rows, args.lead))
    return 0


if __name__ == "__main__":
    sys.exit(main())
