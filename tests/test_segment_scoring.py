"""Found items scored against true items by the pixels they share."""

from __future__ import annotations

import numpy as np

from perception.items.scoring import SEGMENT_KINDS, pooled_segments, score_segments


def test_detected_split_merged_missed_and_spurious():
    # True items 0..4; found items 0..4 (rows), pixels inside each true footprint (columns).
    overlap = np.array(
        [
            [500, 0, 0, 0, 0],  # item 0 on its own
            [0, 300, 0, 0, 0],  # item 1, first half
            [0, 280, 0, 0, 0],  # item 1, second half
            [0, 0, 400, 90, 0],  # items 2 and 3 together
            [0, 0, 0, 0, 0],  # nothing true
        ]
    )
    found_pixels = np.array([510, 300, 290, 495, 60])
    distance = np.full(overlap.shape, 0.5)
    distance[0, 0] = 0.0012
    score = score_segments(overlap, found_pixels, distance)
    assert [SEGMENT_KINDS[k] for k in score.kinds] == [
        "detected",
        "split",
        "merged",
        "merged",
        "missed",
    ]
    np.testing.assert_allclose(score.errors_mm, [1.2], atol=1e-9)
    assert score.median_mm == 1.2
    assert score.spurious == 1 and score.n_found == 5 and score.n_true == 5
    assert score.count("merged") == 2 and score.share("detected") == 0.2


def test_a_small_share_of_a_neighbour_is_no_merge():
    """A found item holding 10 % of a neighbour's pixels (a rim) is still its own item's."""
    overlap = np.array([[500, 30], [0, 270]])
    score = score_segments(overlap, np.array([530, 270]), np.array([[0.001, 0.2], [0.2, 0.002]]))
    assert [SEGMENT_KINDS[k] for k in score.kinds] == ["detected", "detected"]
    np.testing.assert_allclose(np.sort(score.errors_mm), [1.0, 2.0], atol=1e-9)


def test_pooled_scores_add_up():
    one = score_segments(np.array([[100]]), np.array([100]), np.array([[0.003]]))
    none = score_segments(np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)))
    assert [SEGMENT_KINDS[k] for k in none.kinds] == ["missed", "missed"]
    both = pooled_segments([one, none])
    assert both.n_true == 3 and both.count("detected") == 1 and both.count("missed") == 2
    assert both.median_mm == 3.0


def test_the_density_tables_flows_and_its_buried_items(monkeypatch):
    """`sim.evaluation.segmentation_density`: a flow's items from its density (x1: 0.185 m/s,
    60 s), and a missed item counted buried only when the visibility monitor saw under 30 % of
    its top; a recording without visible fractions says nothing."""
    import sim.evaluation.segmentation_density as density
    from perception.items.scoring import SegmentScore
    from sim.evaluation.segmentation_eval import Recording

    assert density.n_items(12.0, 1.0) == 133 and density.n_items(6.0, 1.5, 90.0) == 150
    kinds = np.array([SEGMENT_KINDS.index(k) for k in ("detected", "missed", "missed")])
    score = SegmentScore(kinds, np.array([1.0]), 1, 0)
    monkeypatch.setattr(density, "true_items", lambda recording, types: np.array([3, 7, 8]))
    recording = Recording(1.0, 0, 0.185, [], 0.0, types=(), visible={7: 0.9, 8: 0.1})
    assert density.buried_missed(recording, score) == 1
    assert density.buried_missed(Recording(1.0, 0, 0.185, [], 0.0, types=()), score) is None
    assert density.line("x1 12/m shipped", score, 1).split()[-4:-2] == ["1", "1"]
    assert density.line("x1 12/m shipped", score, None).split()[-4:-2] == ["-", "-"]
