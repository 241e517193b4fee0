"""`sortsim report`: means and Student-t 95 % intervals per grid point, paired comparisons
against a baseline with their intervals and verdicts, short planner labels, figures that decode
(titled in words), one self-contained HTML page, the thesis's layout for a thesis sweep,
refusals before any write."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import imageio.v2 as imageio
import pytest
from scipy import stats

from sim.experiments.report import (
    estimate,
    paired_comparisons,
    paired_difference,
    planner_label,
    planner_labels,
    read_folders,
    summarise,
    write_report,
)

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
    by_planner = {(p["variant"], p["perception"], p["speed"], p["items"], p["planner"]): m
                  for p, m in summary.items()}  # fmt: skip
    fifo = by_planner[("base", "truth", 1.0, 80, "fifo")]
    assert fifo["profit_eur"].mean == pytest.approx(11.0)
    assert fifo["picks_per_min"].mean == pytest.approx(79.0)  # 79 picked in 60 s
    assert by_planner[("base", "truth", 1.0, 80, "lookahead")]["profit_eur"].half_width == 0.0


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
    assert "| x1 | 80 | qlearning | 3 | 17.00 ± 2.48 |" in md  # variant, perception: constant
    assert "Every episode: variant base, truth perception, 1 robot." in md
    assert "Grouped by items, planner: the settings in which the episodes differ." in md
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


def test_recovery_beside_purity_per_material_of_the_catalogue(tmp_path):
    """A sweep of a four-material catalogue: one row per material, in the CSV's order, with its
    recovery beside its bin's purity, means over the seeds; two seeds are marked as too few."""
    path = tmp_path / "four"
    path.mkdir()
    header = "seed,planner,speed_factor,n_items,picked,profit_eur,sim_s,perception,variant,"
    header += "purity_paper,purity_pet,purity_hdpe,purity_aluminium,"
    header += "recovery_paper,recovery_pet,recovery_hdpe,recovery_aluminium\n"
    rows = "0,qlearning,1.000,100,98,25.0,100.0,camera,base,1.0000,0.9500,0.9000,,"
    rows += "0.9000,0.8000,0.7000,0.5000\n"
    rows += "1,qlearning,1.000,100,97,24.0,100.0,camera,base,1.0000,0.9700,0.8000,1.0000,"
    rows += "0.9500,0.8500,0.7500,0.7000\n"
    (path / "episodes.csv").write_text(header + rows)
    write_report([path], tmp_path / "out")
    text = (tmp_path / "out" / "report.md").read_text()
    section = text.split("## Recovery and purity per material")[1].split("\n## ")[0]
    lines = [line for line in section.splitlines() if line.startswith("|")]
    cols = [c.strip() for c in lines[0].strip("|").split("|")]
    assert cols[-5:] == ["material", "seeds", "entered", "recovery", "purity"]
    cells = {
        row[cols.index("material")]: row
        for row in ([c.strip() for c in line.strip("|").split("|")] for line in lines[2:])
    }
    assert list(cells) == ["paper", "pet", "hdpe", "aluminium"]
    assert cells["pet"][cols.index("purity")].startswith("0.960 ± ")
    assert cells["pet"][cols.index("recovery")].startswith("0.825 ± ")
    assert cells["aluminium"][cols.index("purity")] == "1.000"  # one episode had an empty bin
    assert cells["aluminium"][cols.index("seeds")] == "2*"
    assert "fewer than 3 seeds" in section


def _sweep_rows(planner, profits, items=40, speed="1.500"):
    return [
        f"{seed},{planner},{speed},{items},{items - 2},{p:.2f},0.95,30.0,truth,base\n"
        for seed, p in enumerate(profits)
    ]


PROXIMITY = [7.35, 7.54, 7.58, 7.44, 7.49]
GREEDY = [7.19, 7.53, 7.58, 6.98, 7.47]


def test_the_paired_interval_and_p_are_the_paired_t_tests():
    diff, low, high, p = paired_difference(PROXIMITY, GREEDY)
    d = [a - b for a, b in zip(PROXIMITY, GREEDY, strict=True)]
    assert diff == pytest.approx(sum(d) / 5)
    assert p == pytest.approx(stats.ttest_rel(PROXIMITY, GREEDY).pvalue)
    half = stats.t.ppf(0.975, 4) * stats.tstd(d) / math.sqrt(5)
    assert (low, high) == pytest.approx((diff - half, diff + half))
    # the interval excludes 0 exactly when p < 0.05
    assert (low > 0 or high < 0) == (p < 0.05)
    assert paired_difference([1.0, 2.0], [1.0, 2.0]) == (0.0, 0.0, 0.0, 1.0)
    same_gain = paired_difference([2.0, 3.0], [1.0, 2.0])
    assert same_gain == (1.0, 1.0, 1.0, 0.0)
    assert math.isnan(paired_difference([2.0], [1.0])[1])


def test_paired_comparisons_against_the_best_planner_by_default(tmp_path):
    """A 5-seed grid point at x1.5: proximity 7.48 against greedy 7.35 EUR, +0.13 EUR paired,
    p 0.21: no difference; fifo far below on every seed: worse."""
    rows = _sweep_rows("proximity", PROXIMITY) + _sweep_rows("greedy", GREEDY)
    rows += _sweep_rows("fifo", [p - 1.0 for p in PROXIMITY])
    folder = _folder(tmp_path / "sweep", rows)
    comparisons, notes = paired_comparisons(read_folders([folder])[0])
    assert notes == []
    profit = {c.planner: c for c in comparisons if c.metric == "profit_eur"}
    assert set(profit) == {"greedy", "fifo"}  # against proximity, the best by mean profit
    greedy = profit["greedy"]
    assert greedy.baseline == "proximity" and greedy.n == 5
    assert greedy.baseline_mean.mean == pytest.approx(7.48)
    assert greedy.planner_mean.mean == pytest.approx(7.35)
    assert greedy.difference == pytest.approx(-0.13)
    assert greedy.p == pytest.approx(0.21, abs=0.01)
    assert greedy.verdict == "no difference at 95 %"
    assert profit["fifo"].verdict == "worse" and profit["fifo"].difference == pytest.approx(-1.0)
    write_report([folder], tmp_path / "out")
    md = (tmp_path / "out" / "report.md").read_text()
    assert "## Paired comparisons" in md and "paired t-test, scipy.stats.ttest_rel" in md
    line = next(x for x in md.splitlines() if x.startswith("| x1.5 | 40 | greedy | proximity |"))
    assert "| 5 | 7.35 ± 0.32 | 7.48 ± 0.11 | -0.13 [-0.37, +0.11] | 0.21 |" in line
    assert line.endswith("| no difference at 95 % |")
    page = (tmp_path / "out" / "report.html").read_text()
    assert "<h2>Paired comparisons</h2>" in page and "no difference at 95 %" in page
    assert "<td>-0.13 [-0.37, +0.11]</td>" in page


def test_a_named_baseline_and_grid_points_it_did_not_run(tmp_path):
    rows = _sweep_rows("proximity", PROXIMITY) + _sweep_rows("greedy", GREEDY)
    rows += _sweep_rows("proximity", PROXIMITY, items=80)  # greedy did not run at 80 items
    folder = _folder(tmp_path / "sweep", rows)
    comparisons, notes = paired_comparisons(read_folders([folder])[0], baseline="greedy")
    profit = [c for c in comparisons if c.metric == "profit_eur"]
    assert [(c.planner, c.baseline) for c in profit] == [("proximity", "greedy")]
    assert profit[0].difference == pytest.approx(0.13) and profit[0].point["items"] == 40
    assert notes == ["x1.5, 80 items: greedy did not run there."]


def test_pairs_are_the_seeds_both_ran(tmp_path):
    rows = _sweep_rows("proximity", PROXIMITY) + _sweep_rows("greedy", GREEDY[:3])
    folder = _folder(tmp_path / "sweep", rows)
    comparisons, _ = paired_comparisons(read_folders([folder])[0], baseline="greedy")
    c = next(c for c in comparisons if c.metric == "profit_eur")
    assert c.n == 3 and c.planner_mean.mean == pytest.approx(sum(PROXIMITY[:3]) / 3)


def test_an_unknown_baseline_is_refused_before_any_write(tmp_path):
    folder = _folder(tmp_path / "sweep", _sweep_rows("proximity", PROXIMITY))
    proc = subprocess.run(
        [sys.executable, "-m", "sim.cli.main", "report", str(folder), "--baseline", "nope"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "--baseline" in proc.stderr
    assert "proximity" in proc.stderr
    assert not (folder / "report").exists()


USER_PLANNERS = """
class Named:
    name = "mine"

    def choose(self, items, robot, context):
        return None

    def reset(self):
        pass


class Plain:
    def choose(self, items, robot, context):
        return None

    def reset(self):
        pass
"""


def test_user_planners_are_labelled_by_their_name_or_class(tmp_path):
    path = tmp_path / "my_planners.py"
    path.write_text(USER_PLANNERS)
    named, plain = f"{path}:Named", f"{path}:Plain"
    assert planner_label(named) == "mine"
    assert planner_label(plain) == "Plain"
    assert planner_label("/gone/away.py:Gone") == "Gone"  # no longer imports: the class part
    assert planner_label("lookahead") == "lookahead"
    # two specs of the same short name keep their whole specs
    assert planner_labels(["a.py:Gone", "b.py:Gone"]) == {
        "a.py:Gone": "a.py:Gone",
        "b.py:Gone": "b.py:Gone",
    }
    rows = _sweep_rows(named, PROXIMITY) + _sweep_rows(plain, GREEDY)
    folder = _folder(tmp_path / "sweep", rows)
    write_report([folder], tmp_path / "out", baseline="mine")
    md = (tmp_path / "out" / "report.md").read_text()
    assert "| x1.5 | 40 | Plain | mine | 5 |" in md
    assert f"mine = `{named}`" in md
    page = (tmp_path / "out" / "report.html").read_text()
    assert str(tmp_path) not in page.split("Planners:")[1].split("</p>")[1]  # only in the key


def test_figures_are_titled_in_words_and_tables_stay_narrow(tmp_path):
    path = tmp_path / "four"
    path.mkdir()
    header = "seed,planner,speed_factor,n_items,picked,profit_eur,accuracy,sim_s,perception,"
    header += "variant,wrong_bin,missed,failed_picks,energy_elec_j,"
    header += "purity_paper,purity_pet,purity_hdpe,purity_aluminium\n"
    rows = ""
    for planner in ("proximity", "lookahead"):
        for seed in range(3):
            for items in (80, 100):
                rows += f"{seed},{planner},1.000,{items},{items - 2},{20 + seed},0.98,90.0,"
                rows += "camera,base,1,1,0,20000,1.0,0.95,0.90,1.0\n"
    (path / "episodes.csv").write_text(header + rows)
    write_report([path], tmp_path / "out")
    page = (tmp_path / "out" / "report.html").read_text()
    assert "<h2>Profit against items</h2>" in page
    assert ".png" not in page.replace("image/png", "")
    md = (tmp_path / "out" / "report.md").read_text()
    assert "### Profit against items" in md and "![Profit against items](profit_eur.png)" in md
    widths = [line.count("|") - 1 for line in md.splitlines() if line.startswith("|")]
    assert max(widths) <= 11  # no table wider than 11 columns (the purities have their own)
