"""`sortsim sweep`: a small grid, resume after a kill, the thesis's table printed beside ours."""

from __future__ import annotations

import subprocess
import sys
import tomllib

import pytest

from sim.cli import main as cli
from sim.experiments import sweep_config
from sim.experiments import sweep_runner as sweep
from sim.experiments.thesis import thesis_report
from sim.flow.world import WorldVariation
from sim.results import code_digest, outputs

GRID = """
[sweep]
name = "tiny"
table = "4.5"
speed_factors = [1.0]
items = [3]
planners = ["proximity", "qlearning"]
seeds = 1

[base]
perception = "truth"
duration_s = 3.0
"""


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    root = tmp_path_factory.mktemp("sweep")
    path = root / "tiny.toml"
    path.write_text(GRID)
    out = root / "out"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "sim.cli.main",
            "sweep",
            "--config",
            path,
            "--out",
            out,
            "--workers",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    return path, out, proc


def test_one_row_per_episode_in_grid_order(swept):
    _, out, _ = swept
    rows = outputs.read_rows(out / "episodes.csv")
    assert [r["planner"] for r in rows] == ["proximity", "qlearning"]
    assert all(r["n_items"] == "3" and r["variant"] == "base" for r in rows)


def test_picks_of_every_episode_with_its_key_columns(swept):
    """The sweep's picks.csv holds each episode's picks as `sortsim run` writes them, each row
    keyed by its episode (as many as the episode's `attempts`)."""
    _, out, _ = swept
    episodes = outputs.read_rows(out / "episodes.csv")
    picks = outputs.read_rows(out / sweep.PICKS_FILE)
    assert tuple(picks[0]) == outputs.SWEEP_PICK_COLUMNS
    for row in episodes:
        mine = [p for p in picks if sweep.row_key(p) == sweep.row_key(row)]
        assert len(mine) == int(row["attempts"]) > 0
        assert sum(int(p["success"]) for p in mine) == int(row["picked"])


def test_picks_of_an_episode_killed_before_its_row_are_dropped(swept, tmp_path):
    """Killed between the two writes: the next start removes the picks whose episode has no row
    in episodes.csv, so that the rerun episode's picks are not counted twice."""
    path, out, _ = swept
    copy = tmp_path / "out"
    copy.mkdir()
    for name in ("episodes.csv", sweep.PICKS_FILE, sweep.IDENTITY_FILE):
        (copy / name).write_bytes((out / name).read_bytes())
    rows = outputs.read_rows(copy / "episodes.csv")
    outputs.write_episodes(copy / "episodes.csv", rows[:1])
    sweep._start(sweep_config.load(path), copy)
    keys = {sweep.row_key(p) for p in outputs.read_rows(copy / sweep.PICKS_FILE)}
    assert keys == {sweep.row_key(rows[0])}


def test_prints_the_thesis_table_and_saves_the_figures(swept):
    _, out, proc = swept
    assert "Table 4.5" in proc.stdout and "(0.842)" in proc.stdout  # thesis's 84.15 %
    for name in ("figure_4_4_accuracy", "figure_4_5_time", "figure_4_6_profit"):
        assert (out / f"{name}.png").stat().st_size > 1000


def test_resume_runs_only_the_missing_episodes(swept, monkeypatch):
    path, out, _ = swept
    csv_path = out / "episodes.csv"
    rows = outputs.read_rows(csv_path)
    outputs.write_episodes(csv_path, rows[:1])  # as if killed after the first episode
    config = sweep_config.load(path)
    assert [s.key for s in sweep.pending(config, csv_path)] == [config.episodes[1].key]
    ran = []

    def fake_run(spec):
        ran.append(spec.key)
        return {**rows[1]}, [], []

    monkeypatch.setattr(sweep, "run_spec", fake_run)
    again = sweep.run_sweep(config, out, workers=1)
    assert ran == [config.episodes[1].key]
    assert [r["planner"] for r in again] == ["proximity", "qlearning"]
    assert outputs.strip_wall_clock(csv_path.read_text()).count("\n") == 3
    assert sweep.run_sweep(config, out, workers=1) == again and ran == [config.episodes[1].key]


def test_table_formatter_uses_means_over_seeds():
    rows = [
        {"planner": "qlearning", "n_items": "80", "speed_factor": "1.000", "accuracy": a,
         "sim_s": "60", "profit_eur": "10", "variant": "base"}
        for a in ("0.5", "0.7")
    ]  # fmt: skip
    text = thesis_report.format_table("4.5", rows)
    assert "0.600 (0.842)" in text


def test_ray_is_refused_without_the_extra(swept, monkeypatch, capsys):
    path, out, _ = swept
    monkeypatch.setitem(sys.modules, "ray", None)  # as if sortsim[cluster] were not installed
    code = cli.main(["sweep", "--config", str(path), "--out", str(out / "r"), "--ray", "local"])
    err = capsys.readouterr().err
    assert code == 2
    assert "sortsim[cluster]" in err and len(err.strip().splitlines()) == 1
    assert not (out / "r").exists()


@pytest.mark.slow
def test_sweep_on_local_ray(swept, tmp_path):
    path, _, _ = swept
    rows = sweep.run_sweep(sweep_config.load(path), tmp_path, workers=2, ray_address="local")
    assert len(rows) == 2


def blank_episode(spec):
    """A stand-in for the episode runner: the row of the spec's grid point, no picks (the
    sweep's bookkeeping is under test, not the episodes)."""
    c = spec.config
    row = {"seed": c.seed, "planner": c.planner, "speed_factor": c.speed_factor,
           "n_items": c.items, "accuracy": 1.0, "profit_eur": 0.0,
           "code_digest": code_digest.code_digest()}  # fmt: skip
    return row, [], []


def test_results_of_another_sweep_are_refused_not_merged(tmp_path, monkeypatch):
    monkeypatch.setattr(sweep, "run_spec", blank_episode)
    path = tmp_path / "grid.toml"
    path.write_text(GRID)
    out = tmp_path / "out"
    assert len(sweep.run_sweep(sweep_config.load(path), out, workers=1)) == 2
    assert (out / sweep.IDENTITY_FILE).exists()
    # More seeds: the same sweep grown, resumed.
    path.write_text(GRID.replace("seeds = 1", "seeds = 2"))
    assert len(sweep.run_sweep(sweep_config.load(path), out, workers=1)) == 4
    before = (out / "episodes.csv").read_bytes()
    # Another sweep (longer flows) into the same folder: refused before any episode.
    path.write_text(GRID.replace("duration_s = 3.0", "duration_s = 4.0"))
    with pytest.raises(sweep.InvalidInput, match="another sweep"):
        sweep.run_sweep(sweep_config.load(path), out, workers=1)
    assert (out / "episodes.csv").read_bytes() == before


def test_the_progress_bar_reaches_the_end_with_an_eta(tmp_path, monkeypatch):
    monkeypatch.setattr(sweep, "run_spec", blank_episode)
    path = tmp_path / "grid.toml"
    path.write_text(GRID.replace("seeds = 1", "seeds = 2"))
    shown = []
    sweep.run_sweep(
        sweep_config.load(path), tmp_path / "out", workers=1, bar=lambda f, t: shown.append((f, t))
    )
    assert [f for f, _ in shown] == [0.25, 0.5, 0.75, 1.0]
    assert all("ETA" in t for _, t in shown[:-1]) and shown[-1][1] == "4/4 episodes, done"


VARIANTS = """
[sweep]
name = "tiny_variants"
speed_factors = [1.0]
items = [3]
planners = ["proximity"]
seeds = 1

[base]
perception = "truth"
duration_s = 3.0

[[variants]]
name = "unsure"
min_class_confidence = 0.5

[[variants]]
name = "dear_paper"
values = { paper = 0.5 }
"""
VARIANT_COLUMNS = ("variant.min_class_confidence", "variant.values.paper")
ONE_ROBOT = outputs.EPISODE_COLUMNS + ("robots",)
"""A sweep of one robot's columns: `robots` written for one robot too."""


@pytest.fixture(scope="module")
def swept_variants(tmp_path_factory):
    """A real sweep of two tiny episodes, one per variant, each changing another setting."""
    root = tmp_path_factory.mktemp("variants")
    path = root / "variants.toml"
    path.write_text(VARIANTS)
    out = root / "out"
    code = cli.main(["sweep", "--config", str(path), "--out", str(out), "--workers", "1", "-q"])
    assert code == 0
    return path, out


def _header(path) -> tuple[str, ...]:
    return tuple(path.read_text().splitlines()[0].split(","))


def test_a_sweep_without_variants_writes_the_runs_columns(swept):
    _, out, _ = swept
    assert _header(out / "episodes.csv") == ONE_ROBOT
    assert _header(out / sweep.PICKS_FILE) == outputs.SWEEP_PICK_COLUMNS


def test_variant_settings_are_columns_with_the_values_each_episode_ran_with(swept_variants):
    """One column per key any variant sets, after the usual ones, in the file's order; each
    row holds its episode's value, the variant's own or the default (paper's 0.22 EUR)."""
    _, out = swept_variants
    assert _header(out / "episodes.csv") == ONE_ROBOT + VARIANT_COLUMNS
    rows = {r["variant"]: r for r in outputs.read_rows(out / "episodes.csv")}
    assert [rows["unsure"][c] for c in VARIANT_COLUMNS] == ["0.5", "0.22"]
    assert [rows["dear_paper"][c] for c in VARIANT_COLUMNS] == ["0.0", "0.5"]
    assert rows["unsure"]["min_class_confidence"] == "0.5000"  # the run's own column agrees
    picks = outputs.read_rows(out / sweep.PICKS_FILE)
    assert _header(out / sweep.PICKS_FILE) == outputs.SWEEP_PICK_COLUMNS + VARIANT_COLUMNS
    assert {p["variant"] for p in picks} == {"unsure", "dear_paper"}
    for pick in picks:
        assert [pick[c] for c in VARIANT_COLUMNS] == [
            rows[pick["variant"]][c] for c in VARIANT_COLUMNS
        ]


def test_a_folder_written_before_the_variant_columns_resumes_with_them_filled(
    swept_variants, tmp_path, monkeypatch
):
    """Rows of before the columns existed (no such header) get their episode's values when the
    sweep resumes; the episode still missing runs and the file ends in the grid's order."""
    path, out = swept_variants
    rows = outputs.read_rows(out / "episodes.csv")
    picks = outputs.read_rows(out / sweep.PICKS_FILE)
    (tmp_path / sweep.IDENTITY_FILE).write_bytes((out / sweep.IDENTITY_FILE).read_bytes())
    outputs.write_episodes(tmp_path / "episodes.csv", rows[:1])  # the old columns only
    first = [p for p in picks if sweep.row_key(p) == sweep.row_key(rows[0])]
    outputs.write_sweep_picks(tmp_path / sweep.PICKS_FILE, first)
    monkeypatch.setattr(sweep, "run_spec", blank_episode)
    again = sweep.run_sweep(sweep_config.load(path), tmp_path, workers=1)
    assert _header(tmp_path / "episodes.csv") == ONE_ROBOT + VARIANT_COLUMNS
    assert [[r[c] for c in VARIANT_COLUMNS] for r in again] == [["0.5", "0.22"], ["0.0", "0.5"]]
    old_picks = outputs.read_rows(tmp_path / sweep.PICKS_FILE)
    assert len(old_picks) == len(first) > 0
    assert all([p[c] for c in VARIANT_COLUMNS] == ["0.5", "0.22"] for p in old_picks)


def test_variant_keys_in_order_and_a_world_number_left_to_its_preset():
    text = VARIANTS.replace('name = "unsure"', 'name = "unsure"\nsize_jitter = 0.05')
    config = sweep_config.from_dict(tomllib.loads(text), "variants.toml")
    assert config.variant_keys == ("size_jitter", "min_class_confidence", "values.paper")
    unsure, dear = config.episodes
    keys = config.variant_keys
    assert sweep_config.variant_values(unsure, keys)["variant.size_jitter"] == 0.05
    preset = WorldVariation().size_jitter  # the varied world's, which dear_paper runs with
    assert sweep_config.variant_values(dear, keys)["variant.size_jitter"] == preset != 0.05
    assert sweep_config.from_dict(tomllib.loads(GRID), "grid.toml").variant_columns == ()
