"""Bad inputs, as a demanding user gives them, across every subcommand and every file kind.

The README promises that a refused input exits with code 2 and one line on stderr naming the
field and what is allowed, and that nothing is lost. Each case below runs the command line
in-process (`sim.cli.main.main`, argparse's exits caught) and asserts: exit code 2, exactly one
line on stderr, no traceback, and a sentinel output folder (pre-filled with a file) unchanged
afterwards. Every refusal comes before any physics, so the whole file runs in seconds.

Files the user cannot name on the command line (the item catalogue, the MJCF models, the camera
calibration, the cached stripe HMMs) are tested through the loaders the code uses, asserting a
one-line `RefusedInput` naming the file and the field; the calibration and the HMM cache are also
tested through `sortsim run`, which checks them before a camera episode. The rendering
back-end (`MUJOCO_GL`) is read when MuJoCo is imported, so those cases run in subprocesses.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from perception.errors import RefusedInput
from sim.cli.main import main
from sim.paths import CAMERA_CALIBRATION_JSON, MODELS_DIR, REPO_ROOT, ROBOT_XML, SCENE_XML
from sim.results import outputs

# ----- helpers ---------------------------------------------------------------------------------


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under `folder` (hidden ones too) with its bytes."""
    return {
        str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }


@pytest.fixture
def sentinel(tmp_path):
    """An output folder holding an earlier result, which no refused command may touch."""
    folder = tmp_path / "sentinel"
    folder.mkdir()
    (folder / "earlier.csv").write_text("seed,profit_eur\n0,12.5\n", encoding="utf-8")
    return folder


@pytest.fixture
def unwritable(tmp_path):
    """A folder this process may not write in (read-only for a user; a kernel folder for root,
    whom file modes do not stop)."""
    folder = tmp_path / "read_only"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        if os.access(folder, os.W_OK):
            folder = Path("/proc/self")
            if not folder.is_dir() or os.access(folder, os.W_OK):
                pytest.skip("no folder on this machine refuses writes to this process")
        yield folder
    finally:
        (tmp_path / "read_only").chmod(0o755)


def refused(capfd, argv: list[str]) -> str:
    """Run the command line in-process; assert exit 2 and one line on stderr; return it."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse refuses bad option syntax by exiting
        code = exc.code
    err = capfd.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, (argv, code, err)
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert lines[0].startswith("sortsim")
    return lines[0]


def fill(args: list, values: dict[str, object]) -> list[str]:
    """`args` with {placeholders} filled in."""
    return [str(a).format(**values) for a in args]


def episodes_csv(*rows: dict) -> str:
    """An episodes.csv text of `rows` (the other columns empty)."""
    return outputs.to_csv_text(outputs.EPISODE_COLUMNS, rows)


# ----- sortsim run -----------------------------------------------------------------------------

GOOD_TOML = 'items = 2\nduration_s = 2.0\nperception = "truth"\nplanner = "greedy"\n'

# (id, extra arguments, a word the line must hold, files to write: name -> text or bytes)
RUN_CASES = [
    ("items-zero", ["--items", "0"], "items", {}),
    ("items-negative", ["--items", "-3"], "items", {}),
    ("items-huge", ["--items", "1000000000"], "items", {}),
    ("items-text", ["--items", "many"], "--items", {}),
    ("items-float", ["--items", "2.5"], "--items", {}),
    ("items-too-dense", ["--items", "5000", "--duration", "10"], "items", {}),
    ("seed-negative", ["--seed", "-1"], "seed", {}),
    ("seed-huge", ["--seed", str(2**64)], "seed", {}),
    ("seed-text", ["--seed", "x"], "--seed", {}),
    ("speed-2", ["--speed-factor", "2"], "speed_factor", {}),
    ("speed-0.1", ["--speed-factor", "0.1"], "speed_factor", {}),
    ("speed-nan", ["--speed-factor", "nan"], "speed_factor", {}),
    ("speed-inf", ["--speed-factor", "inf"], "speed_factor", {}),
    ("speed-negative", ["--speed-factor", "-1"], "speed_factor", {}),
    ("speed-text", ["--speed-factor", "fast"], "--speed-factor", {}),
    ("planner-unknown", ["--planner", "randomly"], "planner", {}),
    ("planner-empty", ["--planner", ""], "planner", {}),
    ("planner-no-module", ["--planner", "nosuch.module:Picker"], "planner", {}),
    ("planner-no-file", ["--planner", "{tmp}/absent.py:Picker"], "planner", {}),
    ("planner-not-a-class", ["--planner", "os:path"], "planner", {}),
    ("planner-no-choose", ["--planner", "json:JSONDecoder"], "planner", {}),
    ("perception-lidar", ["--perception", "lidar"], "--perception", {}),
    ("duration-zero", ["--duration", "0"], "duration_s", {}),
    ("duration-nan", ["--duration", "nan"], "duration_s", {}),
    ("duration-inf", ["--duration", "inf"], "duration_s", {}),
    ("duration-huge", ["--duration", "1e9"], "duration_s", {}),
    ("min-confidence-negative", ["--min-confidence", "-0.1"], "min_class_confidence", {}),
    ("min-confidence-over-one", ["--min-confidence", "1.5"], "min_class_confidence", {}),
    ("min-confidence-nan", ["--min-confidence", "nan"], "min_class_confidence", {}),
    ("min-confidence-inf", ["--min-confidence", "inf"], "min_class_confidence", {}),
    ("min-confidence-text", ["--min-confidence", "high"], "--min-confidence", {}),
    ("unknown-option", ["--paint", "red"], "unrecognized", {}),
    ("world-unknown", ["--world", "flat"], "--world", {}),
    ("size-jitter-too-large", ["--size-jitter", "0.5"], "size_jitter", {}),
    ("crushed-share-negative", ["--crushed-share", "-0.1"], "crushed_share", {}),
    ("overlap-depth-nan", ["--overlap-depth-m", "nan"], "overlap_depth_m", {}),
    (
        "paper-shares-over-one",
        ["--crumpled-share", "0.7", "--folded-share", "0.5"],
        "folded_share",
        {},
    ),  # fmt: skip
    ("energy-price-negative", ["--energy-price", "-1"], "energy_price_eur_per_kwh", {}),
    ("energy-price-nan", ["--energy-price", "nan"], "energy_price_eur_per_kwh", {}),
    ("energy-price-huge", ["--energy-price", "1e12"], "energy_price_eur_per_kwh", {}),
    ("energy-price-text", ["--energy-price", "cheap"], "--energy-price", {}),
    ("out-is-a-file", ["--out", "{sentinel}/earlier.csv"], "--out", {}),
    ("out-under-a-file", ["--out", "{sentinel}/earlier.csv/deeper"], "--out", {}),
    ("out-unwritable", ["--out", "{unwritable}/out"], "--out", {}),
    ("out-unwritable-itself", ["--out", "{unwritable}"], "--out", {}),
    ("out-csv-is-a-folder", ["--out", "{tmp}/csvdir"], "--out", {"csvdir/episodes.csv/x": ""}),
    ("out-picks-is-a-folder", ["--out", "{tmp}/pdir"], "--out", {"pdir/picks.csv/x": ""}),
    ("video-is-a-folder", ["--video", "{sentinel}"], "--video", {}),
    ("video-trailing-slash", ["--video", "{tmp}/clip.mp4/"], "--video", {}),
    ("video-not-mp4", ["--video", "{tmp}/clip.avi"], "--video", {}),
    ("video-no-suffix", ["--video", "{tmp}/clip"], "--video", {}),
    ("video-under-a-file", ["--video", "{sentinel}/earlier.csv/v.mp4"], "--video", {}),
    ("video-unwritable", ["--video", "{unwritable}/v.mp4"], "--video", {}),
    ("video-is-a-csv", ["--video", "{sentinel}/episodes.csv"], "--video", {}),
    ("config-missing", ["--config", "{tmp}/absent.toml"], "config", {}),
    ("config-folder", ["--config", "{tmp}"], "config", {}),
    ("config-not-utf8", ["--config", "{tmp}/c.toml"], "UTF-8", {"c.toml": b"items = 2 # \xe9\n"}),
    ("config-binary", ["--config", "{tmp}/c.toml"], "config", {"c.toml": b"\x00\xff\xfe\x00"}),
    ("config-malformed", ["--config", "{tmp}/c.toml"], "config", {"c.toml": "items = \n"}),
    ("config-unclosed", ["--config", "{tmp}/c.toml"], "config", {"c.toml": "items = [\n"}),
    ("config-unknown-key", ["--config", "{tmp}/c.toml"], "colour", {"c.toml": "colour = 3\n"}),
    ("config-items-nan", ["--config", "{tmp}/c.toml"], "items", {"c.toml": "items = nan\n"}),
    ("config-items-inf", ["--config", "{tmp}/c.toml"], "items", {"c.toml": "items = inf\n"}),
    ("config-items-bool", ["--config", "{tmp}/c.toml"], "items", {"c.toml": "items = true\n"}),
    ("config-items-text", ["--config", "{tmp}/c.toml"], "items", {"c.toml": 'items = "5"\n'}),
    ("config-items-float", ["--config", "{tmp}/c.toml"], "items", {"c.toml": "items = 2.5\n"}),
    ("config-seed-huge", ["--config", "{tmp}/c.toml"], "seed", {"c.toml": "seed = 9e30\n"}),
    (
        "config-speed-nan",
        ["--config", "{tmp}/c.toml"],
        "speed_factor",
        {"c.toml": "speed_factor = nan\n"},
    ),  # noqa: E501
    (
        "config-duration-inf",
        ["--config", "{tmp}/c.toml"],
        "duration_s",
        {"c.toml": "duration_s = inf\n"},
    ),  # noqa: E501
    (
        "config-period-nan",
        ["--config", "{tmp}/c.toml"],
        "observation_period_s",
        {"c.toml": "observation_period_s = nan\n"},
    ),  # noqa: E501
    (
        "config-riding",
        ["--config", "{tmp}/c.toml"],
        "item_riding",
        {"c.toml": 'item_riding = "air"\n'},
    ),  # noqa: E501
    ("config-planner-number", ["--config", "{tmp}/c.toml"], "planner", {"c.toml": "planner = 3\n"}),  # noqa: E501
    ("config-values-scalar", ["--config", "{tmp}/c.toml"], "values", {"c.toml": "values = 3\n"}),
    (
        "config-values-nan",
        ["--config", "{tmp}/c.toml"],
        "values.paper",
        {"c.toml": "[values]\npaper = nan\n"},
    ),  # noqa: E501
    (
        "config-values-inf",
        ["--config", "{tmp}/c.toml"],
        "values.plastic",
        {"c.toml": "[values]\nplastic = inf\n"},
    ),  # noqa: E501
    (
        "config-values-negative",
        ["--config", "{tmp}/c.toml"],
        "values.aluminium",
        {"c.toml": "[values]\naluminium = -3\n"},
    ),  # noqa: E501
    (
        "config-values-unknown",
        ["--config", "{tmp}/c.toml"],
        "values.glass",
        {"c.toml": "[values]\nglass = 1\n"},
    ),  # noqa: E501
    (
        "config-gamma-nan",
        ["--config", "{tmp}/c.toml"],
        "qlearning.gamma",
        {"c.toml": "[qlearning]\ngamma = nan\n"},
    ),  # noqa: E501
    (
        "config-gamma-one",
        ["--config", "{tmp}/c.toml"],
        "qlearning.gamma",
        {"c.toml": "[qlearning]\ngamma = 1.0\n"},
    ),  # noqa: E501
    (
        "config-iterations-zero",
        ["--config", "{tmp}/c.toml"],
        "qlearning.iterations",
        {"c.toml": "[qlearning]\niterations = 0\n"},
    ),  # noqa: E501
    (
        "config-objective",
        ["--config", "{tmp}/c.toml"],
        "qlearning.objective",
        {"c.toml": '[qlearning]\nobjective = "money"\n'},
    ),  # noqa: E501
    (
        "config-fps-inf",
        ["--config", "{tmp}/c.toml"],
        "video.fps",
        {"c.toml": "[video]\nfps = inf\n"},
    ),  # noqa: E501
    (
        "config-width-odd",
        ["--config", "{tmp}/c.toml"],
        "video.width",
        {"c.toml": "[video]\nwidth = 641\n"},
    ),  # noqa: E501
    (
        "config-pause-nan",
        ["--config", "{tmp}/c.toml"],
        "robot.pick_pause_s",
        {"c.toml": "[robot]\npick_pause_s = nan\n"},
    ),  # noqa: E501
    (
        "config-pause-long",
        ["--config", "{tmp}/c.toml"],
        "robot.place_pause_s",
        {"c.toml": "[robot]\nplace_pause_s = 60\n"},
    ),  # noqa: E501
    (
        "config-idle-sleep-text",
        ["--config", "{tmp}/c.toml"],
        "robot.idle_sleep",
        {"c.toml": '[robot]\nidle_sleep = "yes"\n'},
    ),  # noqa: E501
    (
        "config-infeed-hold-text",
        ["--config", "{tmp}/c.toml"],
        "belt.infeed_hold",
        {"c.toml": '[belt]\ninfeed_hold = "yes"\n'},
    ),  # noqa: E501
    (
        "config-belt-width-wide",
        ["--config", "{tmp}/c.toml"],
        "belt.width_m",
        {"c.toml": "[belt]\nwidth_m = 1.6\n"},
    ),
    ("config-world-unknown", ["--config", "{tmp}/c.toml"], "world", {"c.toml": 'world = "odd"\n'}),
    (
        "config-overlap-share-text",
        ["--config", "{tmp}/c.toml"],
        "overlap_share",
        {"c.toml": 'overlap_share = "lots"\n'},
    ),
    (
        "config-min-confidence-over-one",
        ["--config", "{tmp}/c.toml"],
        "min_class_confidence",
        {"c.toml": "min_class_confidence = 1.2\n"},
    ),
    (
        "config-min-confidence-text",
        ["--config", "{tmp}/c.toml"],
        "min_class_confidence",
        {"c.toml": 'min_class_confidence = "high"\n'},
    ),
    (
        "config-too-dense",
        ["--config", "{tmp}/c.toml"],
        "items",
        {"c.toml": "items = 5000\nduration_s = 10.0\n"},
    ),  # noqa: E501
    (
        "config-faults-overlap",
        ["--config", "{tmp}/c.toml"],
        "faults",
        {
            "c.toml": (
                "[[faults]]\n"
                'kind = "belt_stop"\n'
                "start_s = 10\n"
                "duration_s = 20\n"
                "[[faults]]\n"
                'kind = "belt_stop"\n'
                "start_s = 20\n"
                "duration_s = 5\n"
            )
        },
    ),
    (
        "config-faults-robot-absent",
        ["--config", "{tmp}/c.toml"],
        "faults.robot_stop.robot",
        {"c.toml": '[[faults]]\nkind = "robot_stop"\nstart_s = 10\nduration_s = 5\nrobot = 1\n'},
    ),
    (
        "config-faults-camera-absent",
        ["--config", "{tmp}/c.toml"],
        "faults.camera_outage.camera",
        {
            "c.toml": (
                '[[faults]]\nkind = "camera_outage"\nstart_s = 10\nduration_s = 5\ncamera = 1\n'
            )
        },
    ),
    (
        "config-faults-past-the-end",
        ["--config", "{tmp}/c.toml"],
        "faults.belt_stop.start_s",
        {"c.toml": '[[faults]]\nkind = "belt_stop"\nstart_s = 90\nduration_s = 5\n'},
    ),
    (
        "config-faults-past-the-horizon",
        ["--config", "{tmp}/c.toml"],
        "faults.belt_stop.start_s",
        {
            "c.toml": (
                'horizon_s = 30.0\n[[faults]]\nkind = "belt_stop"\nstart_s = 40\nduration_s = 5\n'
            )
        },
    ),
    (
        "config-faults-kind-unknown",
        ["--config", "{tmp}/c.toml"],
        "faults.kind",
        {"c.toml": '[[faults]]\nkind = "fire"\nstart_s = 10\nduration_s = 5\n'},
    ),
    (
        "config-faults-key-unknown",
        ["--config", "{tmp}/c.toml"],
        "faults[0].colour",
        {"c.toml": '[[faults]]\nkind = "belt_stop"\nstart_s = 10\nduration_s = 5\ncolour = 1\n'},
    ),
    (
        "config-faults-start-missing",
        ["--config", "{tmp}/c.toml"],
        "faults[0].start_s",
        {"c.toml": '[[faults]]\nkind = "belt_stop"\nduration_s = 5\n'},
    ),
    (
        "config-faults-duration-nan",
        ["--config", "{tmp}/c.toml"],
        "faults.belt_stop.duration_s",
        {"c.toml": '[[faults]]\nkind = "belt_stop"\nstart_s = 1\nduration_s = nan\n'},
    ),
    (
        "config-faults-a-table",
        ["--config", "{tmp}/c.toml"],
        "faults",
        {"c.toml": '[faults]\nkind = "belt_stop"\n'},
    ),
    (
        "config-faults-vacuum-above-the-cup",
        ["--config", "{tmp}/c.toml"],
        "faults.vacuum_drop.vacuum_pa",
        {
            "c.toml": (
                '[[faults]]\nkind = "vacuum_drop"\nstart_s = 1\nduration_s = 5\nvacuum_pa = 90000\n'
            )
        },
    ),
    (
        "config-faults-belt-speed-fast",
        ["--config", "{tmp}/c.toml"],
        "faults.belt_speed.speed_factor",
        {
            "c.toml": (
                '[[faults]]\nkind = "belt_speed"\nstart_s = 1\nduration_s = 5\nspeed_factor = 3.0\n'
            )
        },
    ),
    (
        "config-faults-random-kind",
        ["--config", "{tmp}/c.toml"],
        "faults_random.fire",
        {"c.toml": "[faults_random.fire]\nmtbf_s = 60\nmttr_s = 5\n"},
    ),
    (
        "config-faults-random-mttr-missing",
        ["--config", "{tmp}/c.toml"],
        "faults_random.belt_stop.mttr_s",
        {"c.toml": "[faults_random.belt_stop]\nmtbf_s = 60\n"},
    ),
    (
        "config-faults-random-mtbf-zero",
        ["--config", "{tmp}/c.toml"],
        "faults_random.robot_stop.mtbf_s",
        {"c.toml": "[faults_random.robot_stop]\nmtbf_s = 0\nmttr_s = 5\n"},
    ),
    (
        "config-faults-random-robot-key",
        ["--config", "{tmp}/c.toml"],
        "faults_random.robot_stop.robot",
        {"c.toml": "[faults_random.robot_stop]\nmtbf_s = 60\nmttr_s = 5\nrobot = 0\n"},
    ),
    (
        "config-faults-random-vacuum-missing",
        ["--config", "{tmp}/c.toml"],
        "faults_random.vacuum_drop.vacuum_pa",
        {"c.toml": "[faults_random.vacuum_drop]\nmtbf_s = 60\nmttr_s = 5\n"},
    ),
    (
        "config-profile-descending",
        ["--config", "{tmp}/c.toml"],
        "infeed.profile",
        {"c.toml": "[infeed]\nprofile = [[20, 1.0], [10, 2.0]]\n"},
    ),
    (
        "config-profile-negative-factor",
        ["--config", "{tmp}/c.toml"],
        "infeed.profile",
        {"c.toml": "[infeed]\nprofile = [[10, -1.0]]\n"},
    ),
    (
        "config-profile-not-pairs",
        ["--config", "{tmp}/c.toml"],
        "infeed.profile",
        {"c.toml": "[infeed]\nprofile = [10, 2.0]\n"},
    ),
    (
        "config-profile-past-the-feed",
        ["--config", "{tmp}/c.toml"],
        "infeed.profile",
        {"c.toml": "[infeed]\nprofile = [[95, 2.0]]\n"},
    ),
    (
        "config-profile-no-item",
        ["--config", "{tmp}/c.toml"],
        "infeed.profile",
        {"c.toml": "[infeed]\nprofile = [[0, 0.0]]\n"},
    ),
    (
        "config-profile-too-dense",
        ["--config", "{tmp}/c.toml"],
        "infeed.profile",
        {"c.toml": "items = 300\n[infeed]\nprofile = [[30, 2.0]]\n"},
    ),
    (
        "config-surges-too-dense",
        ["--config", "{tmp}/c.toml"],
        "infeed.surges.factor",
        {
            "c.toml": "items = 300\n[infeed]\n"
            "surges = { mean_gap_s = 60, mean_length_s = 10, factor = 2.0 }\n"
        },
    ),
    (
        "config-surges-key-missing",
        ["--config", "{tmp}/c.toml"],
        "infeed.surges.factor",
        {"c.toml": "[infeed]\nsurges = { mean_gap_s = 60, mean_length_s = 10 }\n"},
    ),
    (
        "config-surges-key-unknown",
        ["--config", "{tmp}/c.toml"],
        "infeed.surges.rate",
        {
            "c.toml": "[infeed]\n"
            "surges = { mean_gap_s = 60, mean_length_s = 10, factor = 2.0, rate = 1 }\n"
        },
    ),
    (
        "config-surges-gap-zero",
        ["--config", "{tmp}/c.toml"],
        "infeed.surges.mean_gap_s",
        {"c.toml": "[infeed]\nsurges = { mean_gap_s = 0, mean_length_s = 10, factor = 2.0 }\n"},
    ),
    (
        "config-timeline-period-short",
        ["--config", "{tmp}/c.toml"],
        "timeline.period_s",
        {"c.toml": "[timeline]\nperiod_s = 0.1\n"},
    ),
    (
        "config-timeline-key-unknown",
        ["--config", "{tmp}/c.toml"],
        "timeline.every_s",
        {"c.toml": "[timeline]\nevery_s = 5\n"},
    ),
]


@pytest.mark.parametrize(
    ("args", "word", "files"), [c[1:] for c in RUN_CASES], ids=[c[0] for c in RUN_CASES]
)  # noqa: E501
def test_run_refuses(capfd, tmp_path, sentinel, request, args, word, files):
    values = {"tmp": tmp_path, "sentinel": sentinel}
    if any("{unwritable}" in a for a in args):
        values["unwritable"] = request.getfixturevalue("unwritable")
    for name, content in files.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
    argv = fill(["run", *args], values)
    if "--out" not in argv:
        argv += ["--out", str(sentinel)]
    if "--perception" not in argv and "--config" not in argv:
        argv += ["--perception", "truth"]
    before = snapshot(sentinel)
    line = refused(capfd, [*argv, "--quiet"])
    assert word in line
    assert snapshot(sentinel) == before


# ----- sortsim sweep ---------------------------------------------------------------------------

SWEEP_KEYS = {
    "name": '"tiny"',
    "speed_factors": "[1.0]",
    "items": "[3]",
    "planners": '["proximity"]',
    "seeds": "1",
}
BASE_KEYS = {"perception": '"truth"', "duration_s": "3.0"}


def grid_text(sweep: dict | None = None, base: dict | None = None, tail: str = "") -> str:
    """A small sweep TOML: the defaults above with `sweep` and `base` keys changed (TOML
    literals; None drops a key), then `tail`."""
    sections = []
    for name, keys, changes in (("sweep", SWEEP_KEYS, sweep), ("base", BASE_KEYS, base)):
        merged = {**keys, **(changes or {})}
        body = "".join(f"{k} = {v}\n" for k, v in merged.items() if v is not None)
        sections.append(f"[{name}]\n{body}")
    return "\n".join(sections) + tail


GRID = grid_text()

# (id, the TOML (text, bytes or None for a missing file), a word the line must hold)
SWEEP_CASES = [
    ("missing", None, "config"),
    ("not-utf8", b"[sweep]\nname = '\xe9'\n", "UTF-8"),
    ("malformed", "[sweep\n", "config"),
    ("empty-binary", b"\x00\x01", "config"),
    ("unknown-table", grid_text(tail="[extra]\n"), "extra"),
    ("unknown-sweep-key", grid_text({"speeds": "[1.0]"}), "sweep.speeds"),
    ("base-grid-key", grid_text(base={"seed": "3"}), "base.seed"),
    ("base-unknown-key", grid_text(base={"colour": "3"}), "colour"),
    ("base-perception", grid_text(base={"perception": '"lidar"'}), "perception"),
    ("base-values-nan", grid_text(base={"values": "{ paper = nan }"}), "values.paper"),
    ("base-duration-inf", grid_text(base={"duration_s": "inf"}), "duration_s"),
    ("sweep-not-table", "sweep = 3\n", "sweep"),
    ("items-zero", grid_text({"items": "[10, 0]"}), "items"),
    ("items-empty", grid_text({"items": "[]"}), "sweep.items"),
    ("items-text", grid_text({"items": '["ten"]'}), "items"),
    ("items-scalar", grid_text({"items": "10"}), "sweep.items"),
    ("items-nan", grid_text({"items": "[nan]"}), "items"),
    ("speed-2", grid_text({"speed_factors": "[1.0, 2.0]"}), "speed_factor"),
    ("speed-inf", grid_text({"speed_factors": "[inf]"}), "speed_factor"),
    ("planner-unknown", grid_text({"planners": '["randomly"]'}), "planner"),
    ("planners-empty", grid_text({"planners": "[]"}), "sweep.planners"),
    ("seeds-zero", grid_text({"seeds": "0"}), "sweep.seeds"),
    ("seeds-negative", grid_text({"seeds": "-4"}), "sweep.seeds"),
    ("seeds-huge", grid_text({"seeds": "1000000"}), "sweep.seeds"),
    ("seeds-list-negative", grid_text({"seeds": "[1, -1]"}), "seed"),
    ("seeds-list-text", grid_text({"seeds": '["a"]'}), "seed"),
    ("seed-offset-negative", grid_text({"seed_offset": "-1"}), "sweep.seed_offset"),
    ("seed-offset-float", grid_text({"seed_offset": "1.5"}), "sweep.seed_offset"),
    ("durations-not-table", grid_text({"duration_s_by_items": "3"}), "duration_s_by_items"),
    (
        "durations-other-items",
        grid_text({"duration_s_by_items": "{ 80 = 61.0 }"}),
        "duration_s_by_items",
    ),  # noqa: E501
    ("durations-nan", grid_text({"duration_s_by_items": "{ 3 = nan }"}), "duration_s"),
    ("variants-not-array", "variants = 3\n" + GRID, "variants"),
    (
        "variant-no-name",
        grid_text(tail="[[variants]]\nvalues = { paper = 1.0 }\n"),
        "variants.name",
    ),  # noqa: E501
    (
        "variants-same-name",
        grid_text(tail='[[variants]]\nname = "a"\n[[variants]]\nname = "a"\n'),
        "variants.name",
    ),  # noqa: E501
    (
        "variant-bad-key",
        grid_text(tail='[[variants]]\nname = "a"\nvalues = { glass = 1.0 }\n'),
        "values.glass",
    ),  # noqa: E501
    (
        "variant-nan",
        grid_text(tail='[[variants]]\nname = "a"\nvalues = { paper = nan }\n'),
        "values.paper",
    ),  # noqa: E501
    ("grid-point-too-dense", grid_text({"items": "[3, 4000]"}), "items"),
    ("repeated-axis", grid_text({"items": "[3, 3]"}), "sweep"),
    (
        "too-many-episodes",
        grid_text({"items": "[1, 2, 3, 4, 5, 6, 7, 8, 9, 10]", "seeds": "100000"}),
        "at most",
    ),  # noqa: E501
    ("name-table", grid_text({"name": "{ a = 1 }"}), "sweep.name"),
]


@pytest.mark.parametrize(
    ("text", "word"), [c[1:] for c in SWEEP_CASES], ids=[c[0] for c in SWEEP_CASES]
)  # noqa: E501
def test_sweep_config_refused(capfd, tmp_path, sentinel, text, word):
    path = tmp_path / "grid.toml"
    if text is not None:
        path.write_bytes(text if isinstance(text, bytes) else text.encode())
    before = snapshot(sentinel)
    line = refused(capfd, ["sweep", "--config", path, "--out", sentinel, "--workers", "2"])
    assert word in line and str(path) in line, line
    assert snapshot(sentinel) == before


REFUSING_PLANNER = """
from sim.errors import InvalidInput


class Refuser:
    def reset(self):
        raise InvalidInput("refuser", "no episode: this planner refuses them all")

    def choose(self, items, robot, context):
        return None
"""


def test_a_refusal_in_a_worker_stops_a_two_worker_sweep_in_one_line(tmp_path, sentinel):
    """The grid point passes the load's checks; its episode is refused in a worker process."""
    planner = tmp_path / "refuser.py"
    planner.write_text(REFUSING_PLANNER)
    config = tmp_path / "grid.toml"
    config.write_text(grid_text({"planners": f'["proximity", "{planner}:Refuser"]'}))
    before = snapshot(sentinel)
    start = time.perf_counter()
    proc = _cli(["sweep", "--config", config, "--out", sentinel, "--workers", "2"], "egl", 60)
    elapsed = time.perf_counter() - start
    lines = [line for line in proc.stderr.splitlines() if line.startswith("sortsim")]
    assert proc.returncode == 2, proc.stderr
    assert lines == ["sortsim sweep: refuser: allowed no episode: this planner refuses them all"]
    assert "Traceback" not in proc.stderr
    # No hang (the 60 s timeout above would end one): typically 5-7 s, most of it starting the
    # workers; up to 26 s measured on a 2-core machine busy with a sweep.
    assert elapsed < 45, elapsed
    after = snapshot(sentinel)
    assert {k: v for k, v in after.items() if k in before} == before  # sweep.json may be added


def test_sweep_grid_point_refusal_names_its_coordinates(capfd, tmp_path, sentinel):
    path = tmp_path / "grid.toml"
    path.write_text(grid_text({"items": "[3, 4000]"}))
    line = refused(capfd, ["sweep", "--config", path, "--out", sentinel])
    assert "items 4000" in line and "planner 'proximity'" in line and "seed 0" in line


SWEEP_OUT_CASES = [
    ("out-is-a-file", "{sentinel}/earlier.csv", "--out", {}),
    ("out-under-a-file", "{sentinel}/earlier.csv/deeper", "--out", {}),
    ("out-unwritable", "{unwritable}/out", "--out", {}),
    ("csv-is-a-folder", "{sentinel}", "--out", {"episodes.csv/x": ""}),
    ("identity-is-a-folder", "{sentinel}", "--out", {"sweep.json/x": ""}),
    ("csv-not-utf8", "{sentinel}", "episodes.csv", {"episodes.csv": b"seed\n\xff\xfe\n"}),
    ("csv-ragged", "{sentinel}", "episodes.csv", {"episodes.csv": "seed,planner\n1,a,b,c\n"}),
    ("csv-not-a-sweep", "{sentinel}", "episodes.csv", {"episodes.csv": "seed,planner\n1,fifo\n"}),
    ("csv-of-another-sweep", "{sentinel}", "--out", "foreign"),
    ("csv-of-another-identity", "{sentinel}", "--out", "other-identity"),
    ("identity-corrupt", "{sentinel}", "sweep.json", "corrupt-identity"),
]


def _foreign_rows() -> str:
    row = {"seed": 0, "planner": "fifo", "speed_factor": 1.0, "n_items": 7, "variant": "base"}
    return episodes_csv(row)


def _own_rows() -> str:
    row = {"seed": 0, "planner": "proximity", "speed_factor": 1.0, "n_items": 3, "variant": "base"}
    return episodes_csv(row)


@pytest.mark.parametrize(
    ("out", "word", "files"), [c[1:] for c in SWEEP_OUT_CASES], ids=[c[0] for c in SWEEP_OUT_CASES]
)  # noqa: E501
def test_sweep_output_refused(capfd, tmp_path, sentinel, request, out, word, files):
    values = {"sentinel": sentinel}
    if "{unwritable}" in out:
        values["unwritable"] = request.getfixturevalue("unwritable")
    if files == "foreign":  # rows of another grid, from before sweep.json existed
        files = {"episodes.csv": _foreign_rows()}
    elif files == "other-identity":  # this grid's rows, but recorded as another sweep's
        files = {"episodes.csv": _own_rows(), "sweep.json": '{"identity": "0123456789abcdef"}'}
    elif files == "corrupt-identity":
        files = {"episodes.csv": _own_rows(), "sweep.json": "{not json"}
    for name, content in files.items():
        path = sentinel / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
    config = tmp_path / "grid.toml"
    config.write_text(GRID)
    before = snapshot(sentinel)
    line = refused(capfd, ["sweep", "--config", config, "--out", out.format(**values)])
    assert word in line, line
    assert snapshot(sentinel) == before


SWEEP_OPTION_CASES = [
    ("workers-zero", ["--workers", "0"], "--workers"),
    ("workers-negative", ["--workers", "-2"], "--workers"),
    ("workers-huge", ["--workers", "100000"], "--workers"),
    ("workers-text", ["--workers", "all"], "--workers"),
    ("seeds-zero", ["--seeds", "0"], "--seeds"),
    ("seeds-negative", ["--seeds", "-1"], "--seeds"),
    ("no-config", ["--config"], "--config"),
    ("config-folder", ["--config", "{tmp}"], "config"),
]


@pytest.mark.parametrize(
    ("args", "word"), [c[1:] for c in SWEEP_OPTION_CASES], ids=[c[0] for c in SWEEP_OPTION_CASES]
)  # noqa: E501
def test_sweep_options_refused(capfd, tmp_path, sentinel, args, word):
    config = tmp_path / "grid.toml"
    config.write_text(GRID)
    argv = ["sweep", "--out", sentinel, *fill(args, {"tmp": tmp_path})]
    if "--config" not in argv:
        argv += ["--config", config]
    before = snapshot(sentinel)
    assert word in refused(capfd, argv)
    assert snapshot(sentinel) == before


# ----- sortsim cycle and the MJCF models -------------------------------------------------------

ROBOT_TEXT = ROBOT_XML.read_text(encoding="utf-8")

# (id, edit of the robot's MJCF: (old, new) or bytes or None for a missing file, a needed word)
MJCF_CASES = [
    ("missing", None, "no such file"),
    ("empty", b"", "does not compile"),
    ("not-xml", b"this is not a model\n", "does not compile"),
    ("truncated", ROBOT_TEXT[: len(ROBOT_TEXT) // 2].encode(), "does not compile"),
    (
        "not-utf8",
        ROBOT_TEXT.replace("<mujoco", "<!-- \xe9 --><mujoco", 1).encode("latin-1"),
        "UTF-8",
    ),  # noqa: E501
    ("unknown-element", ("<option ", "<optoin "), "does not compile"),
    ("no-cup-site", ('name="cup_site"', 'name="cup_point"'), "cup_site"),
    ("no-cup-geom", ('name="cup_collision"', 'name="cup_geom"'), "cup_collision"),
    ("no-motor-2", ('<position name="motor_2"', '<position name="motor_two"'), "motor_2"),
    ("no-axis4-actuator", ('<position name="axis4"', '<position name="axis_4"'), "axis4"),
    ("no-home-key", ('<key name="home"', '<key name="rest"'), "home"),
    ("no-platform-joint", ('name="platform_joint"', 'name="platform_free"'), "platform_joint"),
    ("no-base-link", ('<body name="base_link"', '<body name="base"'), "base_link"),
    ("nan-position", ('pos="0 0 0.905"', 'pos="0 0 nan"'), "NaN"),
    ("inf-mass", ('mass="30"', 'mass="inf"'), "NaN or infinite"),
    ("inf-timestep", ('timestep="0.001"', 'timestep="inf"'), "timestep"),
    ("zero-timestep", ('timestep="0.001"', 'timestep="0"'), "timestep"),
]


def _mjcf(tmp_path: Path, edit) -> Path:
    path = tmp_path / "robot.xml"
    if isinstance(edit, bytes):
        path.write_bytes(edit)
    elif edit is not None:
        old, new = edit
        assert old in ROBOT_TEXT, old
        path.write_text(ROBOT_TEXT.replace(old, new, 1), encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("edit", "word"), [c[1:] for c in MJCF_CASES], ids=[c[0] for c in MJCF_CASES]
)  # noqa: E501
def test_cycle_refuses_a_broken_robot_model(capfd, tmp_path, monkeypatch, sentinel, edit, word):
    path = _mjcf(tmp_path, edit)
    monkeypatch.setattr("sim.evaluation.cycle1.ROBOT_XML", path)
    before = snapshot(sentinel)
    line = refused(capfd, ["cycle", "--payload", "1"])
    assert str(path) in line and word in line, line
    assert snapshot(sentinel) == before


@pytest.mark.parametrize(
    ("edit", "word"), [c[1:] for c in MJCF_CASES], ids=[c[0] for c in MJCF_CASES]
)  # noqa: E501
def test_robot_loader_refuses_in_one_line(tmp_path, edit, word):
    from sim.model.mjcf import load_robot

    path = _mjcf(tmp_path, edit)
    with pytest.raises(RefusedInput) as exc:
        load_robot(path)
    message = str(exc.value)
    assert "\n" not in message and str(path) in message and word in message, message


def _scene(tmp_path: Path, old: str = "", new: str = "") -> Path:
    text = SCENE_XML.read_text(encoding="utf-8")
    text = text.replace('file="../abb_irb360/irb360.xml"', f'file="{ROBOT_XML}"')
    text = text.replace('file="items.xml"', f'file="{MODELS_DIR / "cell" / "items.xml"}"')
    assert old in text, old
    path = tmp_path / "scene.xml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


SCENE_CASES = [
    ("no-belt", ('<geom name="belt"', '<geom name="conveyor"'), "'belt'"),
    ("no-camera", ('name="belt_camera"', 'name="camera_0"'), "belt_camera"),
    ("no-marker", ('name="marker_2"', 'name="marker_x"'), "marker_2"),
    ("no-bin-drop", ('name="bin_paper_drop"', 'name="bin_paper_top"'), "bin_paper_drop"),
    ("no-rail", ('name="rail_left"', 'name="rail_l"'), "rail_left"),
]


@pytest.mark.parametrize(
    ("edit", "word"), [c[1:] for c in SCENE_CASES], ids=[c[0] for c in SCENE_CASES]
)  # noqa: E501
def test_scene_loader_names_the_missing_element(tmp_path, edit, word):
    from sim.model.mjcf import load_scene

    path = _scene(tmp_path, *edit)
    with pytest.raises(RefusedInput) as exc:
        load_scene(path)
    message = str(exc.value)
    assert "\n" not in message and str(path) in message and word in message, message
    assert len(message) < 200  # not every name the model has


CYCLE_CASES = [
    ("payload-negative", ["--payload", "-1"], "--payload"),
    ("payload-heavy", ["--payload", "4"], "--payload"),
    ("payload-nan", ["--payload", "nan"], "--payload"),
    ("payload-inf", ["--payload", "inf"], "--payload"),
    ("payload-text", ["--payload", "heavy"], "--payload"),
    ("unknown-option", ["--speed", "2"], "unrecognized"),
]


@pytest.mark.parametrize(
    ("args", "word"), [c[1:] for c in CYCLE_CASES], ids=[c[0] for c in CYCLE_CASES]
)  # noqa: E501
def test_cycle_refuses(capfd, sentinel, args, word):
    before = snapshot(sentinel)
    assert word in refused(capfd, ["cycle", *args])
    assert snapshot(sentinel) == before


# ----- sortsim calibrate -----------------------------------------------------------------------

CALIBRATE_CASES = [
    ("poses-few", ["--poses", "3"], "--poses"),
    ("poses-many", ["--poses", "100000"], "--poses"),
    ("poses-text", ["--poses", "some"], "--poses"),
    ("seed-negative", ["--seed", "-1"], "--seed"),
    ("seed-huge", ["--seed", str(2**40)], "--seed"),
    ("width-tiny", ["--width", "16", "--height", "9"], "--width"),
    ("width-huge", ["--width", "100000"], "--width"),
    ("aspect", ["--width", "1280", "--height", "1280"], "--height"),
    ("aspect-odd", ["--width", "1000"], "--height"),
    ("height-negative", ["--height", "-720"], "--height"),
    ("out-folder", ["--out", "{sentinel}"], "--out"),
    ("out-trailing-slash", ["--out", "{tmp}/cal.json/"], "--out"),
    ("out-not-json", ["--out", "{sentinel}/cal.txt"], "--out"),
    ("out-under-a-file", ["--out", "{sentinel}/earlier.csv/cal.json"], "--out"),
    ("out-unwritable", ["--out", "{unwritable}/cal.json"], "--out"),
    ("scene-missing", ["--scene", "{tmp}/absent.xml"], "absent.xml"),
    ("scene-folder", ["--scene", "{tmp}"], "not a file"),
    ("scene-not-utf8", ["--scene", "{tmp}/bad.xml"], "UTF-8"),
    ("scene-not-xml", ["--scene", "{tmp}/text.xml"], "does not compile"),
    ("scene-no-camera", ["--scene", "{tmp}/scene.xml"], "belt_camera"),
]


@pytest.mark.parametrize(
    ("args", "word"), [c[1:] for c in CALIBRATE_CASES], ids=[c[0] for c in CALIBRATE_CASES]
)  # noqa: E501
def test_calibrate_refuses(capfd, tmp_path, sentinel, request, args, word):
    values = {"tmp": tmp_path, "sentinel": sentinel}
    if any("{unwritable}" in a for a in args):
        values["unwritable"] = request.getfixturevalue("unwritable")
    (tmp_path / "bad.xml").write_bytes(b"<mujoco model='\xe9'/>")
    (tmp_path / "text.xml").write_text("not a model")
    _scene(tmp_path, 'name="belt_camera"', 'name="camera_0"')
    argv = ["calibrate", *fill(args, values)]
    if "--out" not in argv:  # never the committed calibration
        argv += ["--out", str(sentinel / "cal.json")]
    before = snapshot(sentinel)
    assert word in refused(capfd, argv)
    assert snapshot(sentinel) == before


# ----- sortsim hmm-eval ------------------------------------------------------------------------

HMM_EVAL_CASES = [
    ("train-seeds-text", ["--train-seeds", "abc"], "--train-seeds"),
    ("train-seeds-negative", ["--train-seeds", "-1"], "--train-seeds"),
    ("train-seeds-empty", ["--train-seeds", ""], "--train-seeds"),
    ("train-seeds-reversed", ["--train-seeds", "5-2"], "--train-seeds"),
    ("train-seeds-millions", ["--train-seeds", "0-99999999"], "--train-seeds"),
    ("train-seeds-huge", ["--train-seeds", str(2**40)], "--train-seeds"),
    ("test-seeds-text", ["--test-seeds", "x-y"], "--test-seeds"),
    ("test-seeds-overlap", ["--train-seeds", "0-3", "--test-seeds", "2"], "--test-seeds"),
    ("extra-seeds-bad", ["--extra-seeds", "1,,2"], "--extra-seeds"),
    ("iterations-negative", ["--iterations", "-1"], "--iterations"),
    ("iterations-huge", ["--iterations", "100000"], "--iterations"),
    ("tol-nan", ["--tol", "nan"], "--tol"),
    ("tol-negative", ["--tol", "-1"], "--tol"),
    ("anchor-negative", ["--anchor", "-1"], "--anchor"),
    ("anchor-inf", ["--anchor", "inf"], "--anchor"),
    ("smoothing-zero", ["--smoothing", "0"], "--smoothing"),
    ("smoothing-nan", ["--smoothing", "nan"], "--smoothing"),
    ("batch-rows-zero", ["--batch-rows", "0"], "--batch-rows"),
    ("decode-unknown", ["--decode", "viterbi"], "--decode"),
    ("perception-unknown", ["--perception", "lidar"], "--perception"),
    ("save-folder", ["--save", "{sentinel}"], "--save"),
    ("save-trailing-slash", ["--save", "{tmp}/models/"], "--save"),
    ("save-empty", ["--save", ""], "--save"),
    ("save-under-a-file", ["--save", "{sentinel}/earlier.csv/m.npz"], "--save"),
    ("save-unwritable", ["--save", "{unwritable}/m.npz"], "--save"),
    ("save-npz-folder", ["--save", "{tmp}/m.npz"], "--save"),
]


@pytest.mark.parametrize(
    ("args", "word"), [c[1:] for c in HMM_EVAL_CASES], ids=[c[0] for c in HMM_EVAL_CASES]
)  # noqa: E501
def test_hmm_eval_refuses(capfd, tmp_path, sentinel, request, args, word):
    values = {"tmp": tmp_path, "sentinel": sentinel}
    if any("{unwritable}" in a for a in args):
        values["unwritable"] = request.getfixturevalue("unwritable")
    (tmp_path / "m.npz").mkdir()
    argv = ["hmm-eval", *fill(args, values)]
    if "--save" not in argv:  # an accepted case would write here, and fail the sentinel check
        argv += ["--save", str(sentinel / "models.npz")]
    before = snapshot(sentinel)
    assert word in refused(capfd, argv)
    assert snapshot(sentinel) == before


# ----- sortsim bench ---------------------------------------------------------------------------

BENCH_CASES = [
    ("only-unknown", ["--only", "nosuchbench"], "--only"),
    ("only-empty", ["--only", ""], "--only"),
    ("only-path", ["--only", "../episode"], "--only"),
    ("only-prefixed", ["--only", "bench_episode"], "--only"),
    ("unknown-option", ["--fast"], "unrecognized"),
]


@pytest.mark.parametrize(
    ("args", "word"), [c[1:] for c in BENCH_CASES], ids=[c[0] for c in BENCH_CASES]
)  # noqa: E501
def test_bench_refuses(capfd, sentinel, args, word):
    before = snapshot(sentinel)
    assert word in refused(capfd, ["bench", *args])
    assert snapshot(sentinel) == before


REPORT_HEADER = "seed,planner,speed_factor,n_items,picked,profit_eur\n"
REPORT_CASES = [
    ("missing-folder", ["{tmp}/absent"], {}, "DIR"),
    ("no-episodes", ["{tmp}/run"], {"run/picks.csv": "t_start_s\n"}, "DIR"),
    ("header-only", ["{tmp}/run"], {"run/episodes.csv": REPORT_HEADER}, "DIR"),
    ("not-utf8", ["{tmp}/run"], {"run/episodes.csv": b"\xff\xfe\x00garbage"}, "episodes.csv"),
    ("ragged", ["{tmp}/run"], {"run/episodes.csv": REPORT_HEADER + "0,fifo\n"}, "episodes.csv"),
    (
        "speed-text",
        ["{tmp}/run"],
        {"run/episodes.csv": REPORT_HEADER + "0,fifo,fast,80,70,12.0\n"},
        "speed_factor",
    ),
    (
        "items-missing",
        ["{tmp}/run"],
        {"run/episodes.csv": "seed,planner,speed_factor\n0,fifo,1.0\n"},
        "n_items",
    ),
    (
        "out-is-a-file",
        ["{tmp}/run", "--out", "{sentinel}/earlier.csv"],
        {"run/episodes.csv": REPORT_HEADER + "0,fifo,1.0,80,70,12.0\n"},
        "--out",
    ),
    ("no-folder", [], {}, "DIR"),
]


@pytest.mark.parametrize(
    ("args", "files", "word"), [c[1:] for c in REPORT_CASES], ids=[c[0] for c in REPORT_CASES]
)
def test_report_refuses(capfd, tmp_path, sentinel, args, files, word):
    for name, content in files.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
    before = snapshot(sentinel)
    line = refused(capfd, fill(["report", *args], {"tmp": tmp_path, "sentinel": sentinel}))
    assert word in line
    assert snapshot(sentinel) == before
    assert not (tmp_path / "run" / "report").exists()


def test_unknown_command_is_refused(capfd):
    assert "invalid choice" in refused(capfd, ["simulate"])


# ----- the item catalogue ----------------------------------------------------------------------

CATALOGUE_TEXT = (REPO_ROOT / "sim" / "data" / "items.toml").read_text(encoding="utf-8")
FIRST_ITEM = CATALOGUE_TEXT.index("[[item]]")

# (id, edit: (old, new) on the shipped catalogue, or bytes, or None for a missing file, field)
CATALOGUE_CASES = [
    ("missing", None, "catalogue"),
    ("not-utf8", CATALOGUE_TEXT.replace("# Item", "# \xe9 Item", 1).encode("latin-1"), "catalogue"),  # noqa: E501
    ("malformed", ("[colours]", "[colours"), "catalogue"),
    ("unknown-table", ("[colours]", "[glass]\nx = 1\n[colours]"), "glass"),
    ("colours-missing-red", ("\nred = ", "\nmagenta = "), "colours"),
    (
        "colours-not-table",
        "colours = 3\n" + CATALOGUE_TEXT.replace("[colours]", "[palette]"),
        "colours",
    ),  # noqa: E501
    ("colour-nan", ("\nred = [", "\nred = [nan, "), "colours.red"),
    ("colour-out-of-range", ("\nred = [", "\nred = [2, "), "colours.red"),
    ("colour-text", ("\nred = [", '\nred = ["a", '), "colours.red"),
    ("item-not-array", "item = 3\n" + CATALOGUE_TEXT.replace("[[item]]", "[[goods]]"), "item"),
    ("item-unknown-table", CATALOGUE_TEXT + "\n[[goods]]\nname = 'x'\n", "goods"),
    ("item-missing-mass", ("mass = ", "weight_kg = "), "mass"),
    ("item-extra-key", ("mass = ", "glue = 1\nmass = "), "glue"),
    ("item-name-number", ('name = "', 'name = 3\nlabel = "'), "name"),
    ("item-name-empty", ('name = "', 'name = ""\nlabel = "'), "name"),
    ("material-glass", ('material = "paper"', 'material = "glass"'), "material"),
    ("material-number", ('material = "paper"', "material = 2"), "material"),
    ("shape-sphere", ('shape = "box"', 'shape = "sphere"'), "shape"),
    ("pose-standing-box", ('pose = "flat"', 'pose = "standing"'), "pose"),
    ("size-two", ("size = [", "size = [0.1, 0.1]\nx_size = ["), "size"),
    ("size-nan", ("size = [", "size = [nan, "), "size"),
    ("size-inf", ("size = [", "size = [inf, "), "size"),
    ("size-text", ("size = [", 'size = ["big", '), "size"),
    ("size-scalar", ("size = [", "size = 3\nx_size = ["), "size"),
    ("size-negative", ("size = [", "size = [-0.1, "), "size"),
    ("mass-nan", ("mass = ", "mass = nan\nx_mass = "), "mass"),
    ("mass-inf", ("mass = ", "mass = inf\nx_mass = "), "mass"),
    ("mass-heavy", ("mass = ", "mass = 5.0\nx_mass = "), "mass"),
    ("mass-text", ("mass = ", 'mass = "light"\nx_mass = '), "mass"),
    ("friction-two", ("friction = [", "friction = [0.5, 0.1]\nx_friction = ["), "friction"),
    ("friction-nan", ("friction = [", "friction = [nan, "), "friction"),
    ("friction-negative", ("friction = [", "friction = [-1, "), "friction"),
    ("weight-zero", ("weight = ", "weight = 0\nx_weight = "), "weight"),
    ("weight-nan", ("weight = ", "weight = nan\nx_weight = "), "weight"),
    (
        "colour-weights-negative",
        ("colours = {", "colours = { white = -1 }\nx_colours = {"),
        "colours",
    ),  # noqa: E501
    ("colour-weights-nan", ("colours = {", "colours = { white = nan }\nx_colours = {"), "colours"),  # noqa: E501
    (
        "colour-weights-unknown",
        ("colours = {", "colours = { purple = 1 }\nx_colours = {"),
        "colours",
    ),  # noqa: E501
    ("colour-weights-empty", ("colours = {", "colours = {}\nx_colours = {"), "colours"),
    ("colour-weights-list", ("colours = {", "colours = [1, 2]\nx_colours = {"), "colours"),
]


def _edit_catalogue(edit) -> str:
    old, new = edit
    head, items = CATALOGUE_TEXT[:FIRST_ITEM], CATALOGUE_TEXT[FIRST_ITEM:]
    if old in items and not old.startswith(("[colours]", "\nred", "[[item]]")):
        text = head + items.replace(old, new, 1)  # the first item only
    else:
        assert old in CATALOGUE_TEXT, old
        text = CATALOGUE_TEXT.replace(old, new, 1)
    # keys renamed aside by the edit ("x_mass = ...") are dropped again: only the edit remains
    return "\n".join(line for line in text.split("\n") if not line.startswith(("x_", "label")))


@pytest.mark.parametrize(
    ("edit", "field"), [c[1:] for c in CATALOGUE_CASES], ids=[c[0] for c in CATALOGUE_CASES]
)  # noqa: E501
def test_catalogue_refused_in_one_line(tmp_path, edit, field):
    from sim.flow.catalogue import load_catalogue

    path = tmp_path / "items.toml"
    if isinstance(edit, bytes):
        path.write_bytes(edit)
    elif isinstance(edit, str):
        path.write_text(edit, encoding="utf-8")
    elif edit is not None:
        path.write_text(_edit_catalogue(edit), encoding="utf-8")
    with pytest.raises(RefusedInput) as exc:
        load_catalogue(path)
    message = str(exc.value)
    assert "\n" not in message and str(path) in message, message
    assert exc.value.field == field, message


def test_catalogue_duplicate_names_and_missing_material(tmp_path):
    from sim.flow.catalogue import load_catalogue

    path = tmp_path / "items.toml"
    head, items = CATALOGUE_TEXT[:FIRST_ITEM], CATALOGUE_TEXT[FIRST_ITEM:]
    entries = ["[[item]]" + e for e in items.split("[[item]]")[1:]]
    path.write_text(head + entries[0] + entries[0], encoding="utf-8")
    with pytest.raises(RefusedInput) as exc:
        load_catalogue(path)
    assert exc.value.field in ("item.name", "item.material") and str(path) in str(exc.value)


# ----- the camera calibration ------------------------------------------------------------------

CALIBRATION = json.loads(CAMERA_CALIBRATION_JSON.read_text(encoding="utf-8"))


def _calibration(**changes) -> dict:
    data = json.loads(json.dumps(CALIBRATION))
    for key, value in changes.items():
        if value is _DROP:
            data.pop(key)
        else:
            data[key] = value
    return data


_DROP = object()
_M = CALIBRATION["camera_matrix"]

# (id, file content: a dict written as JSON, text, bytes or None for a missing file, field)
CALIBRATION_CASES = [
    ("missing", None, "file"),
    ("not-utf8", b'{"rms_px": "\xe9"}', "file"),
    ("not-json", "calibration: yes", "file"),
    ("json-array", "[1, 2, 3]", "file"),
    ("nan", json.dumps(CALIBRATION).replace("0.19385880220567508", "NaN"), "file"),
    ("infinity", json.dumps(CALIBRATION).replace("624.2262434380376", "Infinity"), "file"),
    ("no-matrix", _calibration(camera_matrix=_DROP), "camera_matrix"),
    ("no-dist", _calibration(dist_coeffs=_DROP), "dist_coeffs"),
    ("no-size", _calibration(image_size=_DROP), "image_size"),
    ("no-rms", _calibration(rms_px=_DROP), "rms_px"),
    ("no-views", _calibration(n_views=_DROP), "n_views"),
    ("matrix-2x2", _calibration(camera_matrix=[[1, 0], [0, 1]]), "camera_matrix"),
    ("matrix-ragged", _calibration(camera_matrix=[[1, 0, 3], [0, 1], [0, 0, 1]]), "camera_matrix"),  # noqa: E501
    ("matrix-text", _calibration(camera_matrix=[["f", 0, 3], _M[1], _M[2]]), "camera_matrix"),
    ("focal-negative", _calibration(camera_matrix=[[-624, 0, 639], _M[1], _M[2]]), "camera_matrix"),  # noqa: E501
    ("focal-zero", _calibration(camera_matrix=[_M[0], [0, 0, 360], _M[2]]), "camera_matrix"),
    ("focal-huge", _calibration(camera_matrix=[[1e9, 0, 639], _M[1], _M[2]]), "camera_matrix"),
    ("centre-outside", _calibration(camera_matrix=[[624, 0, 5000], _M[1], _M[2]]), "camera_matrix"),  # noqa: E501
    ("last-row", _calibration(camera_matrix=[_M[0], _M[1], [0, 0, 2]]), "camera_matrix"),
    (
        "dist-missing-k3",
        _calibration(dist_coeffs={"k1": 0, "k2": 0, "p1": 0, "p2": 0}),
        "dist_coeffs",
    ),  # noqa: E501
    (
        "dist-huge",
        _calibration(dist_coeffs={"k1": 1e9, "k2": 0, "p1": 0, "p2": 0, "k3": 0}),
        "dist_coeffs",
    ),  # noqa: E501
    (
        "dist-text",
        _calibration(dist_coeffs={"k1": "x", "k2": 0, "p1": 0, "p2": 0, "k3": 0}),
        "dist_coeffs",
    ),  # noqa: E501
    ("dist-list", _calibration(dist_coeffs=[0, 0, 0, 0, 0]), "dist_coeffs"),
    ("size-three", _calibration(image_size=[1280, 720, 3]), "image_size"),
    ("size-float", _calibration(image_size=[1280.5, 720]), "image_size"),
    ("size-tiny", _calibration(image_size=[8, 4]), "image_size"),
    ("size-huge", _calibration(image_size=[10**6, 720]), "image_size"),
    ("rms-negative", _calibration(rms_px=-1), "rms_px"),
    ("rms-text", _calibration(rms_px="low"), "rms_px"),
    ("views-zero", _calibration(n_views=0), "n_views"),
    ("views-float", _calibration(n_views=2.5), "n_views"),
    ("views-bool", _calibration(n_views=True), "n_views"),
]


def _write_calibration(path: Path, content) -> Path:
    if isinstance(content, dict):
        path.write_text(json.dumps(content), encoding="utf-8")
    elif isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        path.write_text(content, encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("content", "field"), [c[1:] for c in CALIBRATION_CASES], ids=[c[0] for c in CALIBRATION_CASES]
)  # noqa: E501
def test_calibration_file_refused_in_one_line(tmp_path, content, field):
    from perception.camera.calibration import CameraCalibration

    path = _write_calibration(tmp_path / "cal.json", content)
    with pytest.raises(RefusedInput) as exc:
        CameraCalibration.load(path)
    message = str(exc.value)
    assert "\n" not in message and str(path) in message, message
    assert exc.value.field == field, message


@pytest.mark.parametrize("case", ["nan", "focal-negative", "missing"])
def test_camera_run_refuses_a_bad_calibration_before_the_episode(
    capfd, tmp_path, sentinel, monkeypatch, case
):
    content = dict((c[0], c[1]) for c in CALIBRATION_CASES)[case]
    path = _write_calibration(tmp_path / "cal.json", content)
    monkeypatch.setattr("sim.cell.camera.DEFAULT_CALIBRATION", path)
    before = snapshot(sentinel)
    line = refused(capfd, ["run", "--perception", "camera", "--out", sentinel, "--quiet"])
    assert str(path) in line
    assert snapshot(sentinel) == before


# ----- the cached stripe HMMs ------------------------------------------------------------------


def _hmm_arrays(**changes) -> dict:
    arrays = {
        "format": np.array("sortsim-stripe-hmms"),
        "version": np.array(1),
        "pi": np.full((5, 4), 0.25),
        "A": np.full((5, 1, 4, 4), 0.25),
        "B": np.full((5, 4, 19), 1 / 19),
        "cells_per_item": np.array([np.inf, 20.0, 16.0, 13.0]),
    }
    for key, value in changes.items():
        if value is None:
            arrays.pop(key)
        else:
            arrays[key] = value
    return arrays


def _nan_at(shape, index) -> np.ndarray:
    arr = np.full(shape, 1.0 / shape[-1])
    arr[index] = np.nan
    return arr


HMM_CASES = [
    ("missing", None, "readable"),
    ("not-a-zip", b"these are not models", "readable"),
    ("truncated", "truncated", "readable"),
    ("format", _hmm_arrays(format=np.array("other")), "format"),
    ("version", _hmm_arrays(version=np.array(7)), "format version"),
    ("version-text", _hmm_arrays(version=np.array("one")), "format version"),
    ("no-B", _hmm_arrays(B=None), "missing"),
    ("no-cells", _hmm_arrays(cells_per_item=None), "cells_per_item"),
    ("pi-shape", _hmm_arrays(pi=np.full((4, 4), 0.25)), "pi of shape"),
    ("B-shape", _hmm_arrays(B=np.full((5, 4, 18), 1 / 18)), "B of shape"),
    ("A-shape", _hmm_arrays(A=np.full((5, 2, 4, 4), 0.25)), "A of shape"),
    ("B-nan", _hmm_arrays(B=_nan_at((5, 4, 19), (2, 1, 3))), "finite"),
    (
        "A-inf",
        _hmm_arrays(A=np.where(np.eye(4) > 0, np.inf, 0.25)[None, None] * np.ones((5, 1, 1, 1))),
        "finite",
    ),  # noqa: E501
    ("pi-negative", _hmm_arrays(pi=np.tile([-0.5, 0.5, 0.5, 0.5], (5, 1))), "finite"),
    ("rows-not-stochastic", _hmm_arrays(A=np.full((5, 1, 4, 4), 0.3)), "rows summing to 1"),
    ("pi-text", _hmm_arrays(pi=np.full((5, 4), "x")), "pi"),
    (
        "cells-nan",
        _hmm_arrays(cells_per_item=np.array([np.inf, np.nan, 1.0, 1.0])),
        "cells_per_item",
    ),  # noqa: E501
    (
        "cells-inf",
        _hmm_arrays(cells_per_item=np.array([np.inf, np.inf, 1.0, 1.0])),
        "cells_per_item",
    ),  # noqa: E501
    ("cells-zero", _hmm_arrays(cells_per_item=np.array([1.0, 0.0, 1.0, 1.0])), "cells_per_item"),  # noqa: E501
    ("cells-shape", _hmm_arrays(cells_per_item=np.array([1.0, 2.0])), "cells_per_item"),
]


def _write_hmm(path: Path, content) -> Path:
    if isinstance(content, dict):
        with open(path, "wb") as f:
            np.savez(f, **content)
    elif content == "truncated":
        with open(path, "wb") as f:
            np.savez(f, **_hmm_arrays())
        path.write_bytes(path.read_bytes()[:300])
    elif isinstance(content, bytes):
        path.write_bytes(content)
    return path


@pytest.mark.parametrize(
    ("content", "word"), [c[1:] for c in HMM_CASES], ids=[c[0] for c in HMM_CASES]
)  # noqa: E501
def test_cached_hmms_refused_in_one_line(tmp_path, content, word):
    from sim.sensing.stripe_hmms import read_cache

    path = _write_hmm(tmp_path / "stripe_hmms.npz", content)
    with pytest.raises(RefusedInput) as exc:
        read_cache(path)
    message = str(exc.value)
    assert "\n" not in message and str(path) in message and word in message, message
    assert "delete it" in message


@pytest.mark.parametrize("case", ["B-nan", "not-a-zip"])
def test_camera_run_refuses_a_bad_hmm_cache_before_the_episode(
    capfd, tmp_path, sentinel, monkeypatch, case
):
    path = _write_hmm(tmp_path / "stripe_hmms.npz", dict((c[0], c[1]) for c in HMM_CASES)[case])
    monkeypatch.setattr("sim.sensing.perception.hmm_cache_path", lambda *_args: path)
    before = snapshot(sentinel)
    line = refused(capfd, ["run", "--perception", "camera", "--out", sentinel, "--quiet"])
    assert str(path) in line
    assert snapshot(sentinel) == before


# ----- the rendering back-end (MUJOCO_GL is read when MuJoCo is imported: subprocesses) ---------


def _cli(args: list, gl: str | None, timeout: float = 120) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    if gl is not None:
        env["MUJOCO_GL"] = gl
    return subprocess.run(
        [sys.executable, "-m", "sim.cli.main", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        cwd=REPO_ROOT,
    )


GL_CASES = [
    ("run-camera-unset", ["run", "--perception", "camera"], None),
    ("run-camera-nonsense", ["run", "--perception", "camera"], "nonsense"),
    ("run-video-nonsense", ["run", "--perception", "truth", "--video", "{sentinel}/v.mp4"], "warp"),
    ("calibrate-nonsense", ["calibrate", "--out", "{sentinel}/cal.json"], "nonsense"),
    ("hmm-eval-camera-disabled", ["hmm-eval", "--perception", "camera"], "disable"),
    ("sweep-camera-nonsense", ["sweep", "--config", "{tmp}/cam.toml"], "nonsense"),
]


@pytest.mark.parametrize(("args", "gl"), [c[1:] for c in GL_CASES], ids=[c[0] for c in GL_CASES])
def test_a_bad_rendering_back_end_is_refused_before_any_work(tmp_path, sentinel, args, gl):
    (tmp_path / "cam.toml").write_text(GRID.replace('"truth"', '"camera"'))
    argv = fill(args, {"tmp": tmp_path, "sentinel": sentinel})
    if argv[0] in ("run", "sweep"):
        argv += ["--out", str(sentinel)]
    if argv[0] == "hmm-eval":
        argv += ["--save", str(sentinel / "m.npz")]
    before = snapshot(sentinel)
    proc = _cli(argv, gl, timeout=60)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert "MUJOCO_GL" in lines[0] and "MUJOCO_GL=egl" in lines[0]
    assert repr("unset" if gl is None else gl)[:-1] in lines[0]
    assert snapshot(sentinel) == before


@pytest.mark.parametrize("gl", [None, "nonsense"], ids=["unset", "nonsense"])
def test_truth_runs_need_no_rendering_back_end(tmp_path, gl):
    out = tmp_path / "out"
    proc = _cli(
        ["run", "--perception", "truth", "--items", "1", "--duration", "1", "--out", out,
         "--quiet"],
        gl,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert len(outputs.read_rows(out / "episodes.csv")) == 1
