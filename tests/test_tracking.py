"""Tracking along the belt and the episode's counters, without the simulator."""

from __future__ import annotations

import pytest

from sim.results.metrics import EpisodeMetrics, PickRecord
from sim.sensing.tracking import Detection, Tracker

AL = (0.0, 0.0, 0.1, 0.9)
PAPER = (0.0, 1.0, 0.0, 0.0)


def test_track_advances_with_the_belt_and_merges_repeated_detections():
    tracker = Tracker(belt_speed=0.2, match_radius=0.05)
    [track] = tracker.update([Detection(1.0, -1.4, 0.1, AL)])
    assert track.x_at(3.0, 0.2) == pytest.approx(-1.0)
    assert track.predicted_class == 4 and track.predicted_name == "aluminium"
    # Seen again half a period later 1 cm off: the same item, averaged.
    assert tracker.update([Detection(1.5, -1.29, 0.1, AL)]) == []
    assert len(tracker) == 1 and track.hits == 2
    assert track.x_at(1.5, 0.2) == pytest.approx(-1.295)
    # Another class at the same place, or the same class far away: new items.
    assert len(tracker.update([Detection(1.5, -1.3, 0.1, PAPER)])) == 1
    assert len(tracker.update([Detection(1.5, -1.1, 0.1, AL)])) == 1
    assert len(tracker) == 3


def test_truth_tracks_follow_the_latest_position_and_are_pruned():
    tracker = Tracker(belt_speed=0.2)
    tracker.update([Detection(0.0, -1.4, 0.0, PAPER, true_id=7)])
    tracker.update([Detection(2.0, -1.05, 0.0, PAPER, true_id=7)])  # slipped 5 cm
    [track] = tracker.tracks()
    assert track.x_at(2.0, 0.2) == pytest.approx(-1.05)
    assert tracker.prune(9.0, x_max=0.7) == []
    assert tracker.prune(12.0, x_max=0.7)[0] is track and len(tracker) == 0
    tracker.update([Detection(0.0, -1.4, 0.0, PAPER, true_id=8)])
    tracker.remove_true(8)
    assert len(tracker) == 0


def test_metrics_accuracy_profit_and_wrong_bins():
    m = EpisodeMetrics({2: 0.22, 3: 0.25, 4: 0.27})
    for item, cls in enumerate((2, 3, 4, 4)):
        m.on_entered(item, cls)
    m.on_binned(0, 2, 2)
    m.on_binned(2, 4, 3)  # an aluminium can in the plastic bin earns nothing
    m.on_binned(2, 4, 4)  # counted once
    m.on_missed(1)
    m.on_dropped(3)
    m.on_pick(PickRecord(1.0, 1.6, 0, 2, 2, 2, True))
    m.on_pick(PickRecord(1.6, 2.0, -1, None, 4, 4, False))
    row = m.row()
    assert (row["entered"], row["picked"], row["wrong_bin"]) == (4, 2, 1)
    assert row["accuracy"] == pytest.approx(0.5)
    assert row["profit_eur"] == pytest.approx(0.22)
    assert (row["picked_paper"], row["picked_aluminium"], row["missed"], row["dropped"]) == (
        1,
        1,
        1,
        1,
    )
    assert row["mean_cycle_s"] == pytest.approx(0.6) and row["failed_picks"] == 1
    assert [p["true_class"] for p in m.pick_rows()] == ["paper", "none"]
