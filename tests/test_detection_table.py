"""The report's detection against density (`sim.results.detection_table`) and the run
summary's detection lines."""

from sim.cli.run import _detection_lines
from sim.results.detection_table import detection_markdown, detection_rows


def _row(items, seed, entered, never, visible, picked, perception="camera", density=None):
    return {
        "variant": "v",
        "planner": "qlearning",
        "speed_factor": "1.000",
        "n_items": str(items),
        "seed": str(seed),
        "perception": perception,
        "entered": str(entered),
        "never_detected": str(never),
        "never_visible": "" if visible is None else str(visible),
        "picked": str(picked),
        "items_per_m": "" if density is None else f"{density:.3f}",
    }


def test_shares_are_pooled_over_seeds_and_rows_ordered_by_density():
    rows = [
        _row(300, 0, 300, 30, 12, 250, density=18.0),
        _row(300, 1, 300, 0, 0, 260, density=18.0),
        _row(100, 0, 100, 1, 0, 99, density=6.0),
        _row(100, 0, 100, 0, None, 100, perception="truth", density=6.0),
    ]
    cells = detection_rows(rows)
    assert [c[3] for c in cells] == ["100", "300"]  # the truth row left out, sparse first
    assert cells[1][4:] == ["18.0", "2", "300.0", "5.0 %", "2.0 %", "255.0"]
    assert cells[0][7] == "1.0 %"
    assert detection_markdown(rows).count("\n") == 3  # head, rule, two rows


def test_without_visibility_or_density_the_cells_say_so():
    cells = detection_rows([_row(200, 0, 200, 10, None, 150)])
    assert cells[0][4] == "-" and cells[0][7] == "5.0 %" and cells[0][8] == "-"
    assert detection_markdown([_row(200, 0, 200, 0, 0, 1, perception="truth")]) == ""


def test_the_summary_gives_never_detected_as_a_share_beside_the_density():
    row = {"entered": 200, "never_detected": 10, "never_visible": 4, "items_per_m": 12.012}
    lines = _detection_lines(row)
    assert "10" in lines[0] and "5.0 % of entered; belt 12.0 items per metre" in lines[0]
    assert "2.0 %" in lines[1]
    assert len(_detection_lines({**row, "never_visible": None})) == 1
