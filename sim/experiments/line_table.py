"""The line sweep's table (`docs/results.md`, "A sorting line") from its episodes.csv.

One row per flow and line variant: items picked (mean, min-max over the seeds), profit (mean),
picked relative to the one-robot line at the same flow, items thrown off (sum over the seeds);
then the coordinated rule's profit against independent picking at each robot count and flow.

    python -m sim.experiments.line_table runs/line/episodes.csv
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
from collections import defaultdict
from pathlib import Path

ONE_ROBOT = "1 robot"


def _variant_order(name: str) -> tuple[int, bool, str]:
    """Robots first (the name's leading count), independent before coordinated, then the name."""
    head = name.split(" ", 1)[0]
    return (int(head) if head.isdigit() else 0, "coordinated" in name, name)


def line_table(rows: list[dict[str, str]]) -> str:
    """The markdown table and the coordination comparison of a line sweep's episodes.csv rows
    (columns `n_items`, `variant`, `picked`, `profit_eur`, `thrown_off`)."""
    groups: dict[tuple[int, str], list[dict[str, str]]] = defaultdict(list)
    for row in rows:
        groups[(int(row["n_items"]), row["variant"])].append(row)
    lines = [
        "| items in 90 s | line | picked (mean, min-max) | profit [EUR] | picked / 1 robot "
        "| thrown off (all seeds) |",
        "|---|---|---|---|---|---|",
    ]
    flows = sorted({n for n, _ in groups})
    for n in flows:
        base = groups.get((n, ONE_ROBOT))
        base_mean = statistics.mean(int(r["picked"]) for r in base) if base else None
        for variant in sorted({v for m, v in groups if m == n}, key=_variant_order):
            group = groups[(n, variant)]
            picked = [int(r["picked"]) for r in group]
            profit = statistics.mean(float(r["profit_eur"]) for r in group)
            thrown = sum(int(float(r["thrown_off"] or 0)) for r in group)
            ratio = f"{statistics.mean(picked) / base_mean:.2f}" if base_mean else ""
            lines.append(
                f"| {n} | {variant} | {statistics.mean(picked):.1f} ({min(picked)}-"
                f"{max(picked)}) | {profit:.2f} | {ratio} | {thrown} |"
            )
    lines.append("")
    for n in flows:
        for k in range(2, 5):
            coord = groups.get((n, f"{k} coordinated"))
            indep = groups.get((n, f"{k} independent"))
            if coord and indep:
                a = sum(float(r["profit_eur"]) for r in coord)
                b = sum(float(r["profit_eur"]) for r in indep)
                lines.append(
                    f"{n} items, {k} robots: coordinated {100 * (a / b - 1):+.2f} % profit"
                )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("episodes_csv", type=Path, help="the line sweep's episodes.csv")
    args = parser.parse_args(argv)
    try:
        with args.episodes_csv.open(newline="") as handle:
            rows = list(csv.DictReader(handle))
    except OSError as exc:
        print(f"line_table: episodes_csv: allowed a readable file (got {exc})", file=sys.stderr)
        return 2
    print(line_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
