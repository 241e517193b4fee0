"""The belt's faults under camera perception: the camera's rows are the belt's travel (its
encoder triggers the frames), so a stopped belt gives no rows and a slowed one fewer a second,
and the cell sorts as it does without the fault. One flow (30 items in 8 s, seed 5) with the
belt at x0.5 / x1.5 for 10 s from 5 s, or stopped 10 s from 15.44 s, while a pick is on its way
down (started at 15.29 s), against the same flow without a fault.

Tolerances: on seeds 5, 6 and 7 of this flow x0.5 changed no count, detected or binned, and
x1.5 none detected (it binned 2-6 fewer: a faster belt leaves the robot less time, with truth
too); the stop binned 22 against 21 (21 when the pick under way lost its item); one item of 30
is allowed either way. With the rows on time, as before this
belt's encoder, the camera's rows go on while the belt stands and come at the set speed's rate
at any speed: the row checks fail there."""

from __future__ import annotations

import functools

import pytest

from sim import config as episode_config
from sim.config.faults import Fault, FaultSchedule
from sim.episode.loop import Episode
from sim.episode.runner import config_cell

ITEMS, DURATION_S, SEED = 30, 8.0, 5
START_S, LENGTH_S = 5.0, 10.0
STOP_S = 15.44
"""The stop's start [s]: the pick started at 15.29 s is on its way down to meet its item."""
SLACK = 1
"""Items a belt fault may change a count by (detected, binned) against the run without it."""


@functools.cache
def _run(fault: Fault | None) -> dict:
    """The run's counts, the camera's rows sampled every 0.25 s as (t [s], rows), and the
    track the robot is picking then (None: idle)."""
    config = episode_config.load(
        None, perception="camera", items=ITEMS, duration_s=DURATION_S, seed=SEED
    )
    rows: list[tuple[float, int]] = []
    under: list[tuple[float, int | None]] = []

    def sample(parts) -> None:
        rows.append((parts.data.time, parts.perception.rows))
        pick = parts.stations[0].pick
        under.append((parts.data.time, None if pick is None else pick.track.track_id))

    schedule = FaultSchedule(() if fault is None else (fault,))
    with Episode(config, config_cell(config), faults=schedule) as episode:
        episode.reset()
        episode.every(0.25, sample)
        episode.run()
        m = episode.metrics
        picks = m.pick_rows()
        return {
            "entered": m.n_entered,
            "ends": len(m.binned) + len(m.missed) + len(m.dropped) + len(m.left_on_belt),
            "binned": set(m.binned),
            "detected": len(m.detected),
            "thrown": len(m.thrown_off),
            "wrong_bin": sum(1 for p in picks if p["success"] and p["true_class"] != p["bin"]),
            "rows": rows,
            "under": under,
            "picks": picks,
        }


def _rows_during(run: dict, start_s: float = START_S) -> list[tuple[float, int]]:
    return [(t, n) for t, n in run["rows"] if start_s + 0.01 < t < start_s + LENGTH_S - 0.01]


def _sorts_as_without_the_fault(run: dict, plain: dict, slower: bool) -> None:
    """Every item accounted for, none thrown, no more in a wrong bin, about as many detected,
    and on a belt no faster (`slower`) about as many binned (a faster one gives the robot less
    time: it misses more, with truth perception too)."""
    assert run["entered"] == run["ends"] == ITEMS
    assert run["thrown"] == 0
    assert run["wrong_bin"] <= plain["wrong_bin"]
    assert run["detected"] >= plain["detected"] - SLACK
    if slower:
        assert len(run["binned"]) >= len(plain["binned"]) - SLACK


def test_a_stopped_belt_takes_no_rows_and_the_camera_cell_sorts_as_without_the_stop():
    plain, stop = _run(None), _run(Fault("belt_stop", STOP_S, LENGTH_S))
    during = _rows_during(stop, STOP_S)
    assert len(during) > 30 and len({n for _, n in during}) == 1  # no frame while it stands
    assert stop["rows"][-1][1] == pytest.approx(plain["rows"][-1][1], abs=2)  # the same travel
    _sorts_as_without_the_fault(stop, plain, slower=True)


@pytest.mark.parametrize("factor", [0.5, 1.5])
def test_a_slowed_or_sped_belt_takes_its_rows_by_travel_and_detects_as_without(factor):
    plain = _run(None)
    run = _run(Fault("belt_speed", START_S, LENGTH_S, speed_factor=factor))
    (t0, n0), (t1, n1) = _rows_during(run)[0], _rows_during(run)[-1]
    period = episode_config.load(None).observation_period_s
    assert (n1 - n0) == pytest.approx((t1 - t0) * factor / period, abs=1)  # rows a second
    _sorts_as_without_the_fault(run, plain, slower=factor < 1.0)


def test_a_pick_under_way_when_the_belt_stops_gives_its_item_back_and_it_is_picked():
    """The chain met the item where the running belt would have carried it: the cup comes down
    beside it and lifts empty; the camera will not see the item again, so its track is given
    back where the belt carried it, and the robot picks it on its next try."""
    stop = _run(Fault("belt_stop", STOP_S, LENGTH_S))
    failed = [p for p in stop["picks"] if not p["success"] and p["t_start_s"] < STOP_S]
    failed = [p for p in failed if p["t_end_s"] > STOP_S]
    assert len(failed) == 1  # the pick on its way down when the belt stopped
    pick = failed[0]
    track = next(k for t, k in stop["under"] if pick["t_start_s"] < t < pick["t_end_s"])
    again = [t for t, k in stop["under"] if t > pick["t_end_s"] and k == track]
    assert again, "the item of the pick the stop spoiled was never picked again"
    retry = next(p for p in stop["picks"] if p["t_start_s"] >= pick["t_end_s"] - 1e-9)
    assert retry["t_start_s"] < again[0] < retry["t_end_s"]
    assert retry["success"]
