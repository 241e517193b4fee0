"""The line sweep's table: means, ranges, the ratio to one robot, the coordination's gain."""

from __future__ import annotations

from sim.experiments.line_table import line_table


def _row(variant: str, seed: int, picked: int, profit: float, thrown: int = 0) -> dict:
    return {
        "n_items": "300",
        "variant": variant,
        "seed": str(seed),
        "picked": str(picked),
        "profit_eur": f"{profit:.2f}",
        "thrown_off": str(thrown),
    }


def test_the_table_summarises_each_line_and_compares_the_coordinations():
    rows = [
        _row("1 robot", 0, 140, 35.0),
        _row("1 robot", 1, 146, 36.0, thrown=1),
        _row("2 coordinated", 0, 280, 70.0),
        _row("2 coordinated", 1, 286, 72.0),
        _row("2 independent", 0, 270, 68.0, thrown=2),
        _row("2 independent", 1, 276, 69.0),
    ]
    lines = line_table(rows).splitlines()
    assert lines[2] == "| 300 | 1 robot | 143.0 (140-146) | 35.50 | 1.00 | 1 |"
    assert lines[3] == "| 300 | 2 independent | 273.0 (270-276) | 68.50 | 1.91 | 2 |"
    assert lines[4] == "| 300 | 2 coordinated | 283.0 (280-286) | 71.00 | 1.98 | 0 |"
    # 142 / 137 - 1 = +3.65 %
    assert lines[-1] == "300 items, 2 robots: coordinated +3.65 % profit"
