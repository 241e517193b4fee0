"""`sortsim report`: means and Student-t 95 % intervals per grid point, figures that decode, one
self-contained HTML page, the thesis's layout for a thesis sweep, refusals before any write."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import imageio.v2 as imageio
import pytest

from sim.experiments.report import estimate, read_folders, summarise, write_report

HEADER = "seed,planner,speed_factor,n_items,picked,profit_eur,accuracy,sim_s,perception,variant\n"


def _folder(path, rows, table=None):
    path.mkdir(parents=True)
    (path / "episodes.csv").write_text(HEADER + "".join(rows))
    if table:
        (path / "manifest.json").write_text(json.dumps({"config": {"table": table}}))
    return path


def _rows(planner, items, profits, speed="1.000"):
    return [
        f"{seed},{planner},{speed},{items},{items - 1},{p:.2f},0.9,60.0,truth,base\n"
        for seed, p in enumerate(profits)
    ]


def test_student_t_interval():
    e = estimate([1.0, 2.0, 3.0])  # sd 1, t(0.975, 2) = 4.3027
    assert e.mean == pytest.approx(2.0)
    assert e.half_width == pytest.approx(4.3027 / math.sqrt(3), rel=1e-4)
    assert math.isnan(estimate([5.0]).half_width)


def test_groups_and_derived_metrics(tmp_path):
    folder = _folder(
        tmp_path / "sweep", _rows("fifo", 80, [10.0, 12.0]) + _rows("lookahead", 80, [13.0, 13.0])
    )
    summary = summarise(read_folders([folder])[0])
    fifo = summary[("base", "truth", 1.0, 80, "fifo")]
    assert fifo["profit_eur"].mean == pytest.approx(11.0)
    assert fifo["picks_per_min"].mean == pytest.approx(79.0)  # 79 picked in 60 s
    assert summary[("base", "truth", 1.0, 80, "lookahead")]["profit_eur"].half_width == 0.0


def test_report_files(tmp_path):
    rows = _rows("proximity", 80, [14.0, 15.0, 16.0]) + _rows("qlearning", 80, [16.0, 17.0, 18.0])
    rows += _rows("proximity", 100, [17.0, 18.0, 19.0])
    rows += _rows("qlearning", 100, [19.0, 20.0, 21.0])
    folder = _folder(tmp_path / "table_4_5", rows, table="4.5")
    written = write_report([folder], tmp_path / "out")
    names = {p.name for p in written}
    assert {"report.md", "report.html", "profit_eur.png", "accuracy.png"} <= names
    image = imageio.imread(tmp_path / "out" / "profit_eur.png")
    assert image.shape[0] > 100 and image.shape[1] > 100
    md = (tmp_path / "out" / "report.md").read_text()
    assert "| base | truth | x1 | 80 | qlearning | 3 | 17.00 ± 2.48 |" in md
    assert "Table 4.5" in md  # the thesis's side-by-side layout
    page = (tmp_path / "out" / "report.html").read_text()
    assert page.count('src="data:image/png;base64,') == len([n for n in names if n.endswith("png")])
    assert "http" not in page.lower().replace('lang="en"', "")


def test_cli_refuses_a_folder_without_episodes(tmp_path):
    (tmp_path / "empty").mkdir()
    proc = subprocess.run(
        [sys.executable, "-m", "sim.cli.main", "report", str(tmp_path / "empty")],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and "DIR" in proc.stderr
    assert not (tmp_path / "empty" / "report").exists()


def test_one_purity_column_per_material_of_the_catalogue(tmp_path):
    """A sweep of a four-material catalogue: the table has each material's purity, in the
    CSV's order, with its mean over the seeds."""
    path = tmp_path / "four"
    path.mkdir()
    header = "seed,planner,speed_factor,n_items,picked,profit_eur,sim_s,perception,variant,"
    header += "purity_paper,purity_pet,purity_hdpe,purity_aluminium\n"
    rows = "0,qlearning,1.000,100,98,25.0,100.0,camera,base,1.0000,0.9500,0.9000,\n"
    rows += "1,qlearning,1.000,100,97,24.0,100.0,camera,base,1.0000,0.9700,0.8000,1.0000\n"
    (path / "episodes.csv").write_text(header + rows)
    write_report([path], tmp_path / "out")
    text = (tmp_path / "out" / "report.md").read_text()
    head = next(line for line in text.splitlines() if line.startswith("| variant"))
    cols = [c.strip() for c in head.strip("|").split("|")]
    purity = [c for c in cols if c.startswith("purity")]
    assert purity == ["purity paper", "purity pet", "purity hdpe", "purity aluminium"]
    row = next(line for line in text.splitlines() if line.startswith("| base"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[cols.index("purity pet")].startswith("0.960")
    assert cells[cols.index("purity aluminium")] == "1.000"  # one episode had an empty bin
