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


# --- a line's camera per robot: one tracker, detections fused across cameras ----------------


def test_the_same_item_seen_by_two_cameras_is_one_track():
    tracker = Tracker(belt_speed=0.2)
    [track] = tracker.update([Detection(1.0, -1.4, 0.1, AL)])  # the first camera
    # 2.3 m downstream, 11.5 s later, 7 cm off where the belt carried it and classed another
    # way: beyond the match radius, within the fusion gate; the second camera's position wins.
    later = Detection(12.5, 0.97, 0.07, PAPER, camera=1)
    assert tracker.update([later]) == []
    assert len(tracker) == 1 and track.camera == 1 and track.hits == 2
    assert track.x_at(12.5, 0.2) == pytest.approx(0.97) and track.y == pytest.approx(0.07)
    assert track.probs.tolist() == pytest.approx([0.0, 0.5, 0.05, 0.45])
    # Reported again by the same camera half a period on: the ordinary match, no new track.
    assert tracker.update([Detection(13.0, 1.07, 0.07, PAPER, camera=1)]) == []
    # The next camera joins it as well.
    assert tracker.update([Detection(22.0, 2.86, 0.08, AL, camera=2)]) == []
    assert len(tracker) == 1 and track.camera == 2


def test_an_item_no_upstream_camera_saw_is_a_new_track():
    tracker = Tracker(belt_speed=0.2)
    tracker.update([Detection(1.0, -1.4, 0.1, AL)])
    # Uncovered by an upstream pick: 25 cm from every track, a new one.
    [new] = tracker.update([Detection(12.5, 0.95, -0.15, AL, camera=1)])
    assert new.camera == 1 and len(tracker) == 2


def test_two_items_next_to_each_other_take_one_track_each():
    tracker = Tracker(belt_speed=0.2)
    a, b = tracker.update([Detection(1.0, -1.4, 0.0, AL), Detection(1.0, -1.4, 0.12, PAPER)])
    # Both within the fusion gate of track a; each detection takes the nearest free track.
    near_b = Detection(12.5, 0.9, 0.09, PAPER, camera=1)
    near_a = Detection(12.5, 0.9, 0.03, AL, camera=1)
    # A third item 7 cm from where track a was is new: each upstream track is taken once.
    third = Detection(12.5, 0.9, -0.07, AL, camera=1)
    [new] = tracker.update([near_b, third, near_a])
    assert a.y == pytest.approx(0.03) and b.y == pytest.approx(0.09)
    assert new.y == pytest.approx(-0.07) and len(tracker) == 3


def test_a_downstream_detection_never_joins_a_track_past_the_gate_or_by_the_match_radius():
    tracker = Tracker(belt_speed=0.2, match_radius=0.06, fusion_gate=0.05)
    [track] = tracker.update([Detection(1.0, -1.4, 0.1, AL)])
    # 5.5 cm off: inside the match radius, outside the fusion gate: another camera's item.
    assert len(tracker.update([Detection(12.5, 0.9, 0.155, AL, camera=1)])) == 1
    assert track.camera == 0 and len(tracker) == 2
    # The first camera's detections never join a downstream camera's track (4.5 cm away).
    assert len(tracker.update([Detection(13.0, 1.0, 0.2, AL)])) == 1


def test_a_track_restored_after_the_belt_changed_speed_is_where_the_belt_carried_it():
    """A track out of the tracker (its pick under way) while the belt stopped and ran on at
    half speed comes back where the belt carried it, not where the old speed would have."""
    tracker = Tracker(belt_speed=0.2)
    [track] = tracker.update([Detection(1.0, -1.0, 0.1, AL)])
    tracker.remove(track.track_id)
    tracker.rebase(2.0, 0.0)  # stopped at 2 s (the track 0.2 m on)
    tracker.rebase(5.0, 0.1)  # on at half speed at 5 s
    tracker.restore(track)
    assert track.x_at(7.0, tracker.belt_speed) == pytest.approx(-1.0 + 0.2 + 0.2)
    # A track kept in the tracker meanwhile is moved by the same rule.
    [kept] = tracker.update([Detection(7.0, 0.5, -0.2, PAPER)])
    tracker.rebase(8.0, 0.2)
    assert kept.x_at(9.0, tracker.belt_speed) == pytest.approx(0.5 + 0.1 + 0.2)
