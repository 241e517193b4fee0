"""The config of a shift: `[[faults]]`, `[faults_random]`, `[infeed] profile` and `surges`,
`[timeline]`; read from a file, written back, drawn by seed and refused in one line at load."""

from __future__ import annotations

import json

import pytest

from sim.config.episode import EpisodeConfig
from sim.config.faults import Fault, RandomFaults
from sim.config.loading import from_dict, load
from sim.config.sections import InfeedRate, Surges
from sim.errors import InvalidInput
from sim.experiments.sweep_config import _resolved

SHIFT_TOML = """\
robots = 2
duration_s = 600.0
items = 1200
perception = "truth"
[[faults]]
kind = "robot_stop"
robot = 1
start_s = 120
duration_s = 30
[[faults]]
kind = "vacuum_drop"
start_s = 300
duration_s = 60
vacuum_pa = 40000
[faults_random.belt_stop]
mtbf_s = 200
mttr_s = 10
[faults_random.camera_outage]
mtbf_s = 300
mttr_s = 5
[infeed]
profile = [[100, 1.5], [200, 0.5]]
surges = { mean_gap_s = 120, mean_length_s = 20, factor = 1.2 }
[timeline]
period_s = 5
"""


@pytest.fixture
def shift(tmp_path):
    path = tmp_path / "shift.toml"
    path.write_text(SHIFT_TOML, encoding="utf-8")
    return path


def test_a_config_without_the_shift_keys_is_todays():
    config = EpisodeConfig()
    assert config.faults == () and config.faults_random == ()
    assert config.rate_steps == () and config.surges is None
    assert config.timeline.period_s == 10.0 and config.peak_rate_factor == 1.0
    assert not config.fault_schedule()
    resolved = json.loads(_resolved("v", config))  # an old sweep's identity keeps
    assert not {"faults", "faults_random", "timeline", "infeed"} & set(resolved)


def test_a_shift_file_loads_writes_back_and_draws_by_seed(shift):
    config = load(shift)
    assert config.faults == (
        Fault("robot_stop", 120.0, 30.0, robot=1),
        Fault("vacuum_drop", 300.0, 60.0, vacuum_pa=40000.0),
    )
    assert config.faults_random == (
        RandomFaults("camera_outage", 300.0, 5.0),
        RandomFaults("belt_stop", 200.0, 10.0),
    )
    assert config.rate_steps == ((100.0, 1.5), (200.0, 0.5))
    assert config.surges == Surges(120.0, 20.0, 1.2)
    assert config.timeline.period_s == 5.0
    assert config.peak_rate_factor == pytest.approx(1.5 * 1.2, abs=1e-12)
    schedule = config.fault_schedule()
    assert set(config.faults) <= set(schedule.faults)
    drawn = [f for f in schedule.faults if f not in config.faults]
    assert {f.kind for f in drawn} == {"belt_stop", "camera_outage"}
    assert all(f.start_s < 600.0 for f in schedule.faults)
    assert schedule == load(shift).fault_schedule()  # the same seed, the same faults
    assert schedule != load(shift, seed=1).fault_schedule()
    assert config.flow_config() == config.replace(faults=(), faults_random=()).flow_config()
    again = from_dict(json.loads(json.dumps(config.to_dict())))  # a manifest's round trip
    assert again == config and again.fault_schedule() == schedule
    assert load(shift, items=600).rate_steps == config.rate_steps  # an option keeps them


def test_the_end_is_the_horizon_when_set_and_the_cameras_the_lines():
    stop = Fault("belt_stop", 50.0, 5.0)
    assert EpisodeConfig(faults=(stop,), perception="truth").end_s == 90.0
    with pytest.raises(InvalidInput) as err:
        EpisodeConfig(faults=(stop,), horizon_s=40.0, perception="truth")
    assert str(err.value).startswith("faults.belt_stop.start_s") and "40 s" in str(err.value)
    outage = Fault("camera_outage", 10.0, 5.0, camera=1)
    line = {"robots": 2, "perception": "camera"}
    per_robot = from_dict({**line, "camera": {"per_robot": True}})
    assert per_robot.camera_count == 2
    assert per_robot.replace(faults=(outage,)).fault_schedule().faults == (outage,)
    for config in (from_dict(line), per_robot.replace(perception="truth")):
        assert config.camera_count == 1
        with pytest.raises(InvalidInput, match=r"^faults\.camera_outage\.camera"):
            config.replace(faults=(outage,))


def test_the_feeds_peak_decides_the_line_cell_and_the_refusal():
    steady = EpisodeConfig(items=150, perception="truth")  # 9 items per metre of belt
    assert not steady.line_cell
    assert steady.replace(infeed=InfeedRate(profile=((30.0, 1.5),))).line_cell
    surges = {"mean_gap_s": 60, "mean_length_s": 5, "factor": 1.5}
    surging = from_dict({"items": 150, "infeed": {"surges": surges}})
    assert surging.line_cell and surging.peak_rate_factor == 1.5
    with pytest.raises(InvalidInput) as err:
        from_dict({"items": 150, "infeed": {"profile": [[0, 4.0]]}}, "f.toml")
    line = str(err.value)
    assert line.startswith("infeed.profile in f.toml: allowed factors of at most 3.33")
    assert "\n" not in line
