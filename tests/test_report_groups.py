"""`sortsim report` groups episodes by every setting in which they differ, names those grouping
columns, refuses a group of episodes that differ in a setting it cannot name, and shows the
recovery per material beside the purity, the figures per hour and what each added robot earns
(`sim.experiments.reporting`). Real runs: short truth-perception episodes of one seed."""

from __future__ import annotations

import json
import math
import shutil

import pytest

from sim import config as episode_config
from sim.cli import main as cli
from sim.cli.run import write_run
from sim.episode.runner import run_episode
from sim.errors import InvalidInput
from sim.experiments.report import read_folders, summarise, write_report
from sim.experiments.reporting.groups import grouping_text, point_of
from sim.results import outputs
from sim.results.economics import payback_years

SHORT = {"perception": "truth", "items": 12, "duration_s": 5.0, "seed": 3}
"""A short flow: 12 items of every material over 5 s, truth perception (seconds of CPU)."""


@pytest.fixture(scope="module")
def line_runs(tmp_path_factory):
    """A two-robot and a three-robot run of the same seed, each in its own run folder."""
    root = tmp_path_factory.mktemp("lines")
    folders = []
    for robots in (2, 3):
        config = episode_config.load(None, robots=robots, **SHORT)
        folder = root / f"robots{robots}"
        write_run(folder, config, run_episode(config))
        folders.append(folder)
    return folders


def _table(md: str, heading: str) -> tuple[list[str], list[list[str]]]:
    """(header cells, row cells) of the first table under `## heading`."""
    section = md.split(f"## {heading}\n")[1].split("\n## ")[0]
    lines = [line for line in section.splitlines() if line.startswith("|")]
    cells = [[c.strip() for c in line.strip("|").split("|")] for line in lines]
    return cells[0], cells[2:]


def test_a_two_and_a_three_robot_run_of_one_seed_are_two_rows(line_runs, tmp_path, capsys):
    """The issue's case: two rows (one per line), the grouping column named, the recovery per
    material shown beside the purity, one seed marked as too few for an interval."""
    out = tmp_path / "report"
    assert cli.main(["report", *map(str, line_runs), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "Grouped by robots: the settings in which the episodes differ." in printed
    md = (out / "report.md").read_text()
    assert "Grouped by robots: the settings in which the episodes differ." in md
    head, rows = _table(md, "Means per grid point")
    assert head[:4] == ["robots", "belt", "items", "planner"]
    assert [r[0] for r in rows] == ["2", "3"] and [r[head.index("n")] for r in rows] == ["1*"] * 2
    head, rows = _table(md, "Recovery and purity per material")
    assert head[-5:] == ["material", "seeds", "entered", "recovery", "purity"]
    episodes = [outputs.read_rows(f / "episodes.csv")[0] for f in line_runs]
    for robots, row in zip(("2", "3"), episodes, strict=True):
        mine = {r[head.index("material")]: r for r in rows if r[0] == robots}
        assert list(mine) == ["paper", "plastic", "aluminium"]
        for material, cells in mine.items():
            assert cells[head.index("recovery")] == f"{float(row[f'recovery_{material}']):.3f}"
    assert "fewer than 3 seeds" in md


def test_robots_are_written_for_one_robot_too(tmp_path):
    config = episode_config.load(None, **SHORT)
    folder = tmp_path / "one"
    write_run(folder, config, run_episode(config))
    row = outputs.read_rows(folder / "episodes.csv")[0]
    assert row["robots"] == "1"
    assert "coordination" not in row  # a single robot has none


def test_what_each_added_robot_earns_and_its_payback(line_runs, tmp_path):
    """The robots' table sets the three-robot line against the two-robot one: its extra profit
    per hour is the difference of the runs' `profit_per_h_eur`, its payback capital / (extra x
    hours - maintenance) at the default economics."""
    write_report(line_runs, tmp_path / "out")
    md = (tmp_path / "out" / "report.md").read_text()
    head, rows = _table(md, "What each added robot earns")
    two, three = (float(outputs.read_rows(f / "episodes.csv")[0]["profit_per_h_eur"])
                  for f in line_runs)  # fmt: skip
    extra = three - two
    assert rows[1][head.index("extra profit/h per added robot [EUR]")] == f"{extra:+.2f}"
    payback = payback_years(75000.0, extra, 4000.0, 3000.0)
    text = "never" if math.isinf(payback) else f"{payback:.1f}"
    assert rows[1][head.index("payback per added robot [years]")] == text
    assert rows[0][head.index("extra profit/h per added robot [EUR]")] == "-"


def test_a_group_of_runs_that_differ_in_an_unnamed_setting_is_refused(line_runs, tmp_path):
    """A copy of the two-robot run whose manifest records another Q-learning discount: the
    report cannot name that setting, so it refuses to average the two, in one line naming it
    (exit 2), before writing anything."""
    copy = tmp_path / "other_gamma"
    shutil.copytree(line_runs[0], copy)
    manifest = json.loads((copy / "manifest.json").read_text())
    manifest["config"]["qlearning"]["gamma"] = 0.5
    (copy / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(InvalidInput) as refused:
        read_folders([line_runs[0], copy])
    assert refused.value.field == "qlearning.gamma"
    assert "0.5" in str(refused.value) and str(copy) in str(refused.value)
    out = tmp_path / "out"
    assert cli.main(["report", str(line_runs[0]), str(copy), "--out", str(out)]) == 2
    assert not out.exists()


def test_code_and_feed_are_grouping_columns_when_they_differ(line_runs, tmp_path):
    """Two copies of one run whose rows record another code digest, or another feed (items
    per metre), are two grid points each, never averaged; a feed that follows the items alone
    is no column of its own."""
    rows = []
    for k, (digest, density) in enumerate((("aaaa", "24.000"), ("bbbb", "12.000"))):
        folder = tmp_path / f"copy{k}"
        shutil.copytree(line_runs[0], folder)
        row = outputs.read_rows(folder / "episodes.csv")[0]
        row |= {"code_digest": digest, "items_per_m": density}
        (folder / "episodes.csv").write_text(outputs.to_csv_text(list(row), [row]))
        rows += read_folders([folder])[0]
    points = list(summarise(rows))
    assert len(points) == 2
    grouped = "Grouped by code, items/m: the settings in which the episodes differ."
    assert grouping_text(points) == grouped
    assert {point_of(r)["code"] for r in rows} == {"aaaa", "bbbb"}
