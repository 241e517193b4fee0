"""`sortsim reproduce`: the list of pieces, the docs' markers, pieces made from tiny sweeps and
resumed, table 4.1's plumbing, and `--only table_4_1 --quick` end to end (slow)."""

from __future__ import annotations

import re
import time

import pytest

from sim.cli.main import main
from sim.errors import InvalidInput
from sim.experiments.thesis import reproduce, reproduce_hmm, reproduce_tables
from sim.experiments.thesis.reproduce import END_MARKER, Run, start_marker, write_block
from sim.experiments.thesis.thesis_report import mean_and_range
from sim.results import code_digest, outputs

NAMES = (
    ["table_4_1", "table_4_2", "table_4_3", "table_4_3_paused", "table_4_4"]
    + ["table_4_5", "table_4_6", "table_4_5_paused", "table_4_6_paused"]
    + ["table_4_5_camera", "table_4_6_camera", "finding_13"]
    + ["table_4_2_paused", "table_4_4_paused", "table_4_5_calibrated", "table_4_6_calibrated"]
    + ["finding_paired", "bound_4_5_4_6"]
    + ["figure_4_1", "figure_4_2", "figure_4_3"]
    + [f"figure_4_{k}" for k in range(4, 10)]
)


def test_list_names_every_table_and_figure(capsys):
    assert main(["reproduce", "--list"]) == 0
    text = capsys.readouterr().out
    listed = re.findall(r"^((?:table|figure|finding|bound)_\w+)\s", text, flags=re.M)
    assert sorted(listed) == sorted(NAMES)
    assert "reproduce_4_5_camera (150 episodes)" in text  # the thesis's 5 seeds
    for sweep in reproduce_tables.random_sweeps():  # the random picker's rows, 5 seeds too
        assert f"{sweep} (25 episodes)" in text
    assert "reproduce_4_5_calibrated (125 episodes)" in text  # 5 planners, 5 datasets, 5 seeds
    assert "Table 4.5: x1, the calibrated regime" in text
    assert "reproduce_4_2_paused (360 episodes)" in text  # the thesis's 10 seeds
    assert "reproduce_4_4_paused (12 episodes)" in text  # its 4
    assert "reproduce_4_6_calibrated_best_order (25 episodes)" in text  # the bound's best order
    assert "25 sweeps, 2114 episodes" in text
    assert main(["reproduce", "--list", "--quick"]) == 0
    quick = capsys.readouterr().out
    assert "reproduce_4_5_camera (30 episodes)" in quick
    assert "reproduce_4_5_random (5 episodes)" in quick


@pytest.mark.parametrize("table", ["4_5", "4_6"])
def test_the_camera_tables_run_the_thesis_path_with_coupled_stripes(tmp_path, table):
    """The camera rows: the thesis's path (classifier "hmm") with its stripes coupled, the fused
    classifier with independent ones, on the truth rows' flows; the block's first line says so."""
    run = Run(tmp_path, quick=True)
    camera = run.sweep(f"reproduce_{table}_camera")
    ran = {(s.variant, s.config.classifier, s.config.hmm.coupled) for s in camera.episodes}
    assert ran == {("camera_hmm", "hmm", True), ("camera_fused", "fused", False)}
    truth = {
        (s.config.items, s.config.seed, s.config.duration_s)
        for s in run.sweep(f"reproduce_{table}").episodes
    }
    assert {(s.config.items, s.config.seed, s.config.duration_s) for s in camera.episodes} == truth
    text = reproduce_tables._coupling_text(camera)
    assert "coupled for camera, stripe HMMs" in text and "independent for camera, fused" in text


def test_the_random_picker_runs_on_the_flows_and_regime_of_its_table():
    """Each random sweep: the same configs as its table's sweep (flows, belt, pauses), but for
    the planner."""
    run = Run(reproduce.DEFAULT_OUT)
    for name in reproduce_tables.random_sweeps():
        base = name.removesuffix("_random")
        ours = {s.config.replace(planner="proximity") for s in run.sweep(name).episodes}
        theirs = {s.config for s in run.sweep(base).episodes if s.config.planner == "proximity"}
        assert ours == theirs, name
        assert {s.config.planner for s in run.sweep(name).episodes} == {"random"}


def test_an_unknown_piece_is_refused_in_one_line(capsys, tmp_path):
    args = ["reproduce", "--only", "table_9_9", "--out", str(tmp_path), "--no-docs"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--only" in err and "table_4_1" in err


DOC = f"""# Results

intro

{start_marker("table_4_5")}
old table
{END_MARKER}

between

{start_marker("figure_4_4")}
{END_MARKER}

tail
"""


def test_the_marker_writer_replaces_only_between_markers_and_is_idempotent():
    once = write_block(DOC, "table_4_5", "| a | b |\n|---|---|\n| 1 | 2 |\n")
    assert once == DOC.replace("old table\n", "| a | b |\n|---|---|\n| 1 | 2 |\n")
    assert write_block(once, "table_4_5", "| a | b |\n|---|---|\n| 1 | 2 |") == once
    both = write_block(once, "figure_4_4", "![f](results/f.png)")
    assert both.endswith(
        f"{start_marker('figure_4_4')}\n![f](results/f.png)\n{END_MARKER}\n\ntail\n"
    )
    assert both.split(start_marker("figure_4_4"))[0] == once.split(start_marker("figure_4_4"))[0]
    assert reproduce.markers_in(both) == ["table_4_5", "figure_4_4"]


@pytest.mark.parametrize(
    ("text", "body"),
    [
        ("no markers\n", "x"),
        (DOC + start_marker("table_4_5") + "\n", "x"),  # twice
        (f"{start_marker('table_4_5')}\nno end\n", "x"),
        (DOC, f"{END_MARKER}\n"),  # a marker inside the block
    ],
)
def test_the_marker_writer_refuses(text, body):
    with pytest.raises(InvalidInput):
        write_block(text, "table_4_5", body)


def _tiny_sweeps(folder, names):
    """The reproduce sweeps, of 3 items over 3 s each, truth perception."""
    for name in names:
        speed = 1.2 if "4_6" in name else 1.0
        pauses = (
            "\n[base.robot]\npick_pause_s = 0.5\nplace_pause_s = 0.5\n" if "paused" in name else ""
        )
        random = name.endswith("_random")
        planners = '["random"]' if random else '["qlearning", "rollout", "proximity"]'
        (folder / f"{name}.toml").write_text(
            f'[sweep]\nname = "{name}"\nspeed_factors = [{speed}]\nitems = [3]\n'
            f"planners = {planners}\nseeds = 3\n\n"
            f'[base]\nperception = "truth"\nduration_s = 3.0\n{pauses}'
        )


def test_pieces_from_tiny_sweeps_resume_and_fill_the_docs(tmp_path):
    sweeps = ["reproduce_4_5", "reproduce_4_6", "reproduce_4_5_paused", "reproduce_4_6_paused"]
    _tiny_sweeps(tmp_path, [*sweeps, "reproduce_4_5_random"])
    docs = tmp_path / "docs" / "results.md"
    docs.parent.mkdir()
    names = ["table_4_5", "figure_4_6"]
    docs.write_text("".join(f"x\n{start_marker(n)}\n{END_MARKER}\n" for n in names) + "end\n")

    def run():
        return Run(
            tmp_path / "out",
            quick=True,
            workers=1,
            figures=docs.parent / "results",
            link="results/",
            experiments=tmp_path,
        )

    made = reproduce.reproduce(names, run(), docs, echo=lambda _: None)
    csv = tmp_path / "out" / "reproduce_4_5" / "episodes.csv"
    rows = outputs.read_rows(csv)
    assert sorted(r["planner"] for r in rows) == ["proximity", "qlearning", "rollout"]
    assert {r["seed"] for r in rows} == {"0"}  # --quick: the first seed
    table = made["table_4_5"].markdown
    assert (
        "sortsim reproduce --only table_4_5 --quick" in table
        and "seeds 0 (1 per grid point)" in table
    )
    assert "qlearning (thesis's algorithm)" in table and "rollout (ours)" in table
    acc = r"[01]\.\d{3}"
    assert re.search(rf"^\| 3 \| {acc} / {acc} / {acc} / {acc} \| ", table, flags=re.M)
    assert "random (thesis's random picker)" in table
    assert "| 80 | - (0.842) / - / - (0.735) / - | - (64.0) / - / - (60.8) / - |" in table
    # The first line names the commit and the code digest every episode ran on.
    commit = r"(commit [0-9a-f]{12}( with uncommitted changes)?|no git commit)"
    first = table.splitlines()[0]
    assert re.search(rf"` from {commit}, code digest [0-9a-f]{{16}}: seeds 0 ", first), first
    assert code_digest.code_digest() in first and "MIXED" not in first
    random_rows = outputs.read_rows(tmp_path / "out" / "reproduce_4_5_random" / "episodes.csv")
    assert [r["planner"] for r in random_rows] == ["random"]
    assert (docs.parent / "results" / "figure_4_6.png").stat().st_size > 10_000
    text = docs.read_text()
    assert "![Figure 4.6: profit](results/figure_4_6.png)" in text and text.endswith("end\n")
    before, stamp = csv.read_bytes(), csv.stat().st_mtime_ns
    time.sleep(0.01)
    again = reproduce.reproduce(names, run(), docs, echo=lambda _: None)  # resumes: nothing to run
    assert csv.read_bytes() == before and csv.stat().st_mtime_ns >= stamp
    assert docs.read_text() == text and again["table_4_5"].markdown == table
    assert len(outputs.read_rows(csv)) == 3


def test_table_4_1_on_few_flows(tmp_path, monkeypatch):
    """The table's plumbing on a few flows of true codes (camera codes stand in by true ones:
    rendered, they take about 40 s a flow; the slow test below renders them)."""
    monkeypatch.setattr(
        reproduce_hmm, "TRUTH_SEEDS", (range(0, 3), range(200, 201), range(100, 102))
    )
    monkeypatch.setattr(reproduce_hmm, "CAMERA_QUICK_SEEDS", (range(0, 2), (), range(100, 101)))
    truth_recordings = reproduce_hmm.recordings
    monkeypatch.setattr(
        reproduce_hmm, "recordings", lambda s, kind, cache=None: truth_recordings(s, "truth")
    )
    block = reproduce_hmm.table_4_1(Run(tmp_path, quick=True))
    text = block.markdown
    assert "On the flows' true codes" in text and "On the camera's codes" in text
    assert text.count("| **average** |") == 2 and "(0.8816)" in text
    accuracy = float(re.search(r"\| \*\*average\*\* \| (\d\.\d{4}) ", text).group(1))
    assert accuracy >= 0.88


@pytest.mark.slow
def test_only_table_4_1_quick(tmp_path, capsys):
    """`sortsim reproduce --only table_4_1 --quick`: rendered camera codes (3 flows)."""
    docs = tmp_path / "results.md"
    docs.write_text(f"{start_marker('table_4_1')}\n{END_MARKER}\n")
    tic = time.perf_counter()
    args = ["reproduce", "--only", "table_4_1", "--quick", "--out", str(tmp_path / "o")]
    assert main([*args, "--docs", str(docs)]) == 0
    print(f"reproduce --only table_4_1 --quick: {time.perf_counter() - tic:.0f} s")
    text = docs.read_text()
    assert text.count("| **average** |") == 2 and "held out 100" in text
    assert sorted(p.name for p in (tmp_path / "o" / "table_4_1").iterdir()) == [
        "camera_0.npz",
        "camera_1.npz",
        "camera_100.npz",
    ]


def test_error_bars_of_equal_values_are_never_negative():
    """Five seeds that all pick every item: the mean of equal floats may round past them."""
    groups = [[0.1] * 3, [1.0, 0.997, 1.0, 1.0, 1.0], [2.0]]
    m, lo, hi = mean_and_range(groups)
    assert sum([0.1] * 3) / 3 > 0.1  # the rounding this guards against
    assert min(lo) >= 0.0 and min(hi) >= 0.0
    assert lo[1] == pytest.approx(m[1] - 0.997) and hi[1] == pytest.approx(1.0 - m[1])
