"""The fault schedule: validation in one line, activity windows, random draws by seed."""

from __future__ import annotations

import pytest

from sim.config.faults import (
    Fault,
    FaultSchedule,
    RandomFaults,
    availability,
    draw_schedule,
)
from sim.errors import InvalidInput


def test_a_fault_holds_over_its_window_only():
    f = Fault("robot_stop", 10.0, 30.0, robot=1)
    assert not f.active(9.999) and f.active(10.0) and f.active(39.999) and not f.active(40.0)
    assert f.label() == "robot_stop 1" and f.end_s == 40.0


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"kind": "fire", "start_s": 0, "duration_s": 1}, "faults.kind"),
        ({"kind": "belt_stop", "start_s": -1, "duration_s": 1}, "faults.belt_stop.start_s"),
        ({"kind": "belt_stop", "start_s": 0, "duration_s": 0}, "faults.belt_stop.duration_s"),
        ({"kind": "belt_stop", "start_s": 0, "duration_s": 1, "robot": 0},
         "faults.belt_stop.robot"),
        ({"kind": "robot_stop", "start_s": 0, "duration_s": 1}, "faults.robot_stop.robot"),
        ({"kind": "belt_speed", "start_s": 0, "duration_s": 1, "speed_factor": 5.0},
         "faults.belt_speed.speed_factor"),
        ({"kind": "vacuum_drop", "start_s": 0, "duration_s": 1}, "faults.vacuum_drop.vacuum_pa"),
    ],
)  # fmt: skip
def test_a_bad_fault_is_refused_in_one_line_naming_its_key(kwargs, field):
    with pytest.raises(InvalidInput) as err:
        Fault(**kwargs)
    assert str(err.value).startswith(field) and "\n" not in str(err.value)


def test_overlapping_faults_of_one_part_are_refused_other_parts_may_overlap():
    a = Fault("robot_stop", 10.0, 30.0, robot=0)
    FaultSchedule((a, Fault("robot_stop", 20.0, 5.0, robot=1), Fault("belt_stop", 15, 5)))
    with pytest.raises(InvalidInput, match="^faults: allowed faults of one kind"):
        FaultSchedule((a, Fault("robot_stop", 39.0, 5.0, robot=0)))
    with pytest.raises(InvalidInput, match="^faults: "):
        FaultSchedule((Fault("camera_outage", 0, 10), Fault("camera_outage", 5, 10, camera=1)))
    FaultSchedule((a, Fault("robot_stop", 40.0, 5.0, robot=0)))  # back to back


def test_the_cell_check_names_what_the_cell_lacks_and_the_end():
    schedule = FaultSchedule((Fault("robot_stop", 10.0, 5.0, robot=2),))
    with pytest.raises(InvalidInput, match=r"^faults.robot_stop.robot: allowed 0..1"):
        schedule.check_cell(robots=2, cameras=1, end_s=90.0)
    late = FaultSchedule((Fault("belt_stop", 90.0, 5.0),))
    with pytest.raises(InvalidInput, match=r"^faults.belt_stop.start_s: allowed a start before"):
        late.check_cell(robots=1, cameras=1, end_s=90.0)
    cam = FaultSchedule((Fault("camera_outage", 1.0, 5.0, camera=1),))
    with pytest.raises(InvalidInput, match=r"^faults.camera_outage.camera"):
        cam.check_cell(robots=1, cameras=1, end_s=None)


def test_random_faults_are_drawn_by_seed_within_the_end_and_keep_the_given_ones():
    spec = (
        RandomFaults("robot_stop", mtbf_s=600.0, mttr_s=60.0),
        RandomFaults("belt_stop", 900, 30),
    )
    given = (Fault("robot_stop", 100.0, 50.0, robot=0),)
    a = draw_schedule(given, spec, seed=3, robots=2, cameras=1, end_s=3600.0)
    assert a == draw_schedule(given, spec, seed=3, robots=2, cameras=1, end_s=3600.0)
    assert a != draw_schedule(given, spec, seed=4, robots=2, cameras=1, end_s=3600.0)
    assert given[0] in a.faults and all(f.end_s <= 3600.0 + 1e-9 for f in a.faults)
    stops = a.of_kind("robot_stop")
    assert {f.robot for f in stops} == {0, 1} and len(a.of_kind("belt_stop")) >= 1
    # 2 robots x 3600 s at 600 s up and 60 s down: about 11 stops; a wide band, not a fit
    assert 4 <= len(stops) <= 24


def test_availability_counts_each_robots_stops_and_the_belts_once():
    schedule = FaultSchedule(
        (Fault("robot_stop", 0.0, 10.0, robot=0), Fault("belt_stop", 5.0, 10.0))
    )
    # robot 0 lost 0-15 s (15 s), robot 1 lost 5-15 s (10 s) of 2 x 100 s
    assert availability(schedule, robots=2, end_s=100.0) == pytest.approx(1 - 25 / 200, abs=1e-12)
    assert availability(FaultSchedule(), robots=2, end_s=100.0) == 1.0
    assert FaultSchedule().downtime_s("belt_stop", 100.0) == 0.0
    assert schedule.downtime_s("belt_stop", 12.0) == pytest.approx(7.0, abs=1e-12)
