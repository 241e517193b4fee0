"""Sorting quality (purity, recovery, never detected, empty picks) and the confidence rule."""

from __future__ import annotations

import math

import pytest

from perception.codes import ALUMINIUM, PAPER, PLASTIC
from planner.decision.interface import TrackedItem
from sim import config
from sim.config.settings import ITEM_CLASSIFIER_MIN_CONFIDENCE
from sim.episode.loop import Episode
from sim.episode.runner import run_episode
from sim.errors import InvalidInput
from sim.experiments import sweep_config
from sim.results import outputs
from sim.results.metrics import EpisodeMetrics, PickRecord
from sim.sensing.attribution import attributed_item
from sim.sensing.confidence import is_unsure, sure_items, top_class_probability
from sim.sensing.tracking import Detection, Track

VALUES = {PAPER: 0.22, PLASTIC: 0.25, ALUMINIUM: 0.27}
CLASS_OF = {"paper": PAPER, "plastic": PLASTIC, "aluminium": ALUMINIUM}


# ----- the metrics' arithmetic on hand-built events -------------------------------------------


def sorted_episode() -> EpisodeMetrics:
    """7 items: 3 paper, 2 plastic, 2 aluminium. Paper bin: paper 0 and 1, plastic 3;
    aluminium bin: aluminium 5; plastic bin empty. Paper 2 missed, plastic 4 dropped,
    aluminium 6 missed. Items 0, 1, 3 and 4 were tracked; 5 was picked untracked (the cup
    sealed on it beside its target)."""
    m = EpisodeMetrics(VALUES)
    for item, cls in enumerate((PAPER, PAPER, PAPER, PLASTIC, PLASTIC, ALUMINIUM, ALUMINIUM)):
        m.on_entered(item, cls)
    for item in (0, 1, 3, 4):
        m.on_detected(item)
    m.on_binned(0, PAPER, PAPER)
    m.on_binned(1, PAPER, PAPER)
    m.on_binned(3, PLASTIC, PAPER)
    m.on_binned(5, ALUMINIUM, ALUMINIUM)
    m.on_missed(2)
    m.on_dropped(4)
    m.on_missed(6)
    for item, cls, bin_class in ((0, PAPER, PAPER), (1, PAPER, PAPER), (3, PLASTIC, PAPER)):
        m.on_pick(PickRecord(1.0 + item, 1.6 + item, item, cls, bin_class, bin_class, True))
    m.on_pick(PickRecord(5.0, 5.6, 5, ALUMINIUM, ALUMINIUM, ALUMINIUM, True))
    m.on_pick(PickRecord(6.0, 6.5, 6, ALUMINIUM, ALUMINIUM, ALUMINIUM, False, sealed=False))
    m.on_pick(PickRecord(7.0, 7.5, 4, PLASTIC, PLASTIC, PLASTIC, False, sealed=True))  # lost
    return m


def test_purity_per_bin_and_recovery_per_class():
    row = sorted_episode().row()
    assert row["purity_paper"] == pytest.approx(2 / 3, abs=1e-12)
    assert row["purity_plastic"] is None  # an empty bin has no purity
    assert row["purity_aluminium"] == pytest.approx(1.0, abs=1e-12)
    assert row["recovery_paper"] == pytest.approx(2 / 3, abs=1e-12)
    assert row["recovery_plastic"] == pytest.approx(0.0, abs=1e-12)
    assert row["recovery_aluminium"] == pytest.approx(0.5, abs=1e-12)
    assert (row["picked"], row["wrong_bin"]) == (4, 1)


def test_never_detected_empty_picks_and_left_unsure():
    m = sorted_episode()
    m.on_left_unsure(2)
    m.on_left_unsure(0)
    row = m.row()
    assert row["never_detected"] == 3  # 2 and 6 missed unseen, 5 picked unseen
    assert row["empty_picks"] == 1 and row["failed_picks"] == 2
    assert row["left_unsure"] == 2


def test_the_identities_hold_and_a_broken_one_is_reported():
    m = sorted_episode()
    assert m.accounting_failures() == []
    m.on_pick(PickRecord(8.0, 8.5, 1, PAPER, PAPER, PAPER, True, sealed=False))
    m.on_detected(99)  # never entered
    fails = m.accounting_failures()
    assert any("never sealed counted as a success" in f for f in fails), fails
    assert any("detected but never entered: [99]" in f for f in fails), fails


def test_undefined_ratios_are_empty_cells_and_the_rest_fixed_decimals():
    m = EpisodeMetrics(VALUES)
    assert all(m.row()[f"purity_{c}"] is None for c in CLASS_OF)
    assert all(m.row()[f"recovery_{c}"] is None for c in CLASS_OF)
    text = outputs.to_csv_text(outputs.EPISODE_COLUMNS, [sorted_episode().row()])
    cells = dict(zip(*(line.split(",") for line in text.splitlines()), strict=True))
    assert cells["purity_paper"] == "0.6667" and cells["purity_plastic"] == ""
    assert cells["recovery_aluminium"] == "0.5000"
    assert (cells["never_detected"], cells["empty_picks"]) == ("3", "1")
    columns = outputs.EPISODE_COLUMNS
    new = columns[columns.index("purity_paper") : columns.index("items_per_m") + 1]
    assert len(new) == 12 and new[-2:] == ("left_unsure", "items_per_m")
    assert {"left_on_belt", "not_arrived", "code_digest"} <= set(columns)


# ----- attributing tracks to true items (camera mode's bookkeeping) ---------------------------


def new_track(x: float, y: float, true_id: int | None = None) -> Track:
    return Track(track_id=0, t0=2.0, x0=x, y=y, probs=(0.0, 0.2, 0.7, 0.1), true_id=true_id)


def test_a_track_is_attributed_to_the_nearest_item_within_the_gate():
    items = {4: (-1.00, 0.00), 5: (-0.97, 0.03), 6: (-1.00, 0.30)}
    # 2 cm from item 5, 3.6 cm from item 4 at the detection time (the track moved 0.0 m).
    assert attributed_item(new_track(-0.98, 0.05), 2.0, 0.185, items, 0.06) == 5
    # Evaluated where the track is at `t`: 1 s later it has moved 0.185 m downstream.
    assert attributed_item(new_track(-1.185, 0.30), 3.0, 0.185, items, 0.06) == 6
    # Beyond the gate: a phantom, attributed to nothing.
    assert attributed_item(new_track(-1.00, 0.15), 2.0, 0.185, items, 0.06) is None
    assert attributed_item(new_track(-1.00, 0.15), 2.0, 0.185, {}, 0.06) is None
    # Equally near two items: the lower id.
    tie = {6: (-1.00, 0.30), 4: (-1.00, 0.00)}
    assert attributed_item(new_track(-1.00, 0.15), 2.0, 0.185, tie, 0.15) == 4


def test_a_track_on_a_long_items_end_is_that_items():
    from sim.flow.catalogue import load_catalogue

    catalogue = load_catalogue()
    bottle = catalogue.types[catalogue.index("pet_bottle_1l5")]  # 31 cm long, 9 cm wide
    sheet = catalogue.types[catalogue.index("paper_scrap")]
    items = {3: (-1.00, 0.00), 4: (-1.00, 0.12)}
    shapes = {3: (0.0, bottle), 4: (0.0, sheet)}
    # 12 cm from the bottle's centre along its axis: beyond the 6 cm gate, on its footprint.
    track = new_track(-0.88, 0.01)
    assert attributed_item(track, 2.0, 0.185, items, 0.06) is None
    assert attributed_item(track, 2.0, 0.185, items, 0.06, shapes) == 3
    # Across it, 7 cm from its axis: off the bottle (4.5 cm radius, 1 cm margin) and off the
    # sheet: the nearest centre within the gate, the sheet's; without the sheet, a phantom.
    assert attributed_item(new_track(-1.00, 0.07), 2.0, 0.185, items, 0.06, shapes) == 4
    assert attributed_item(new_track(-1.00, 0.065), 2.0, 0.185, {3: items[3]}, 0.06, shapes) is None


def test_a_truth_track_is_its_own_item():
    far = {1: (5.0, 5.0)}
    assert attributed_item(new_track(-1.0, 0.0, true_id=8), 2.0, 0.185, far, 0.06) == 8


# ----- the confidence rule ----------------------------------------------------------------------


def item(item_id: int, probs: tuple[float, float, float, float]) -> TrackedItem:
    return TrackedItem(item_id, -1.0, 0.0, probs)


SURE = item(1, (0.0, 0.05, 0.9, 0.05))
SPLIT = item(2, (0.0, 0.45, 0.35, 0.2))
EXACT = item(3, (0.0, 0.2, 0.2, 0.6))
VOIDY = item(4, (0.5, 0.1, 0.35, 0.05))  # void mass does not count towards a material


def test_top_class_probability_is_over_the_materials():
    assert top_class_probability(SURE.class_probs) == pytest.approx(0.9, abs=1e-12)
    assert top_class_probability(VOIDY.class_probs) == pytest.approx(0.35, abs=1e-12)
    assert is_unsure(SPLIT.class_probs, 0.6) and not is_unsure(EXACT.class_probs, 0.6)


def test_sure_items_keeps_order_and_filters_below_the_threshold():
    items = [SPLIT, SURE, EXACT, VOIDY]
    assert sure_items(items, 0.0) == items
    assert [i.item_id for i in sure_items(items, 0.4)] == [2, 1, 3]
    assert [i.item_id for i in sure_items(items, 0.6)] == [1, 3]  # 0.6 itself is sure enough
    assert [i.item_id for i in sure_items(items, 0.95)] == []
    certain = item(5, (0.0, 0.0, 0.0, 1.0))
    assert sure_items([certain], 1.0) == [certain]
    # At a threshold <= 0 every item is sure (probabilities are >= 0), as the rule says.
    for threshold in (0.0, -0.5):
        assert sure_items(items, threshold) == [
            i for i in items if not is_unsure(i.class_probs, threshold)
        ]


# ----- the config key --------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [-0.01, 1.01, 2, math.nan, math.inf, "0.5", True])
def test_min_class_confidence_refuses_what_is_not_a_probability(bad):
    with pytest.raises(InvalidInput) as exc:
        config.EpisodeConfig(min_class_confidence=bad)
    assert exc.value.field == "min_class_confidence"
    assert "min_class_confidence" in str(exc.value) and "[0, 1]" in str(exc.value)


def test_min_class_confidence_from_toml_and_overrides():
    assert config.EpisodeConfig().min_class_confidence is None  # the classifier's own
    assert config.from_dict({"min_class_confidence": 1}).min_class_confidence == 1
    assert config.load(None, min_class_confidence=0.6).min_class_confidence == 0.6
    with pytest.raises(InvalidInput, match="min_class_confidence") as exc:
        config.from_dict({"min_class_confidence": 1.5}, where="grid.toml")
    assert exc.value.where == "grid.toml"


def test_an_unset_threshold_is_the_classifiers_own():
    """0.9 for the camera's item classifier modes, 0 for the HMMs alone and for truth; a set
    threshold wins, 0 included."""
    camera = config.EpisodeConfig(perception="camera")
    assert camera.applied_min_class_confidence == ITEM_CLASSIFIER_MIN_CONFIDENCE == 0.9
    assert camera.replace(classifier="features").applied_min_class_confidence == 0.9
    assert camera.replace(classifier="hmm").applied_min_class_confidence == 0.0
    assert camera.replace(perception="truth").applied_min_class_confidence == 0.0
    assert camera.replace(min_class_confidence=0).applied_min_class_confidence == 0.0
    hmm = config.EpisodeConfig(classifier="hmm", min_class_confidence=0.7)
    assert hmm.applied_min_class_confidence == 0.7
    assert config.from_dict(camera.to_dict()) == camera  # unset stays unset


def test_sweep_identity_holds_the_threshold_applied():
    """A grid point is identified by the threshold its episodes apply: one left to the
    classifier's 0.9 is not a sweep begun when every classifier's default was 0 (that sweep's
    identity has no threshold), while truth, the HMMs and an explicit 0 keep that identity."""
    base = config.EpisodeConfig()  # camera, fused
    assert '"min_class_confidence": 0.9' in sweep_config._resolved("base", base)
    for as_before in (
        base.replace(min_class_confidence=0.0),
        base.replace(classifier="hmm"),
        base.replace(perception="truth"),
    ):
        assert "min_class_confidence" not in sweep_config._resolved("base", as_before)
    unsure = base.replace(min_class_confidence=0.8)
    assert '"min_class_confidence": 0.8' in sweep_config._resolved("base", unsure)


def test_a_sweeps_variant_column_holds_the_threshold_applied():
    sweep = sweep_config.from_dict(
        {
            "sweep": {"name": "rule", "items": [10], "seeds": 1},
            "base": {"duration_s": 10.0},
            "variants": [
                {"name": "truth", "perception": "truth"},
                {"name": "camera", "perception": "camera"},
                {"name": "hmm", "perception": "camera", "classifier": "hmm"},
                {"name": "rule off", "perception": "camera", "min_class_confidence": 0.0},
            ],
        },
        "rule.toml",
    )
    assert sweep.variant_keys == ("perception", "classifier", "min_class_confidence")
    column = "variant.min_class_confidence"
    applied = {
        spec.variant: sweep_config.variant_values(spec, sweep.variant_keys)[column]
        for spec in sweep.episodes
    }
    assert applied == {"truth": 0.0, "camera": 0.9, "hmm": 0.0, "rule off": 0.0}


# ----- physics episodes -------------------------------------------------------------------------

SHORT = dict(items=10, duration_s=8.0, perception="truth", planner="fifo", seed=1)


@pytest.fixture(scope="module")
def truth_run(cell):
    return run_episode(config.load(None, **SHORT), cell=cell)


def test_purity_and_recovery_match_the_picks(truth_run):
    row, picks = truth_run.episode_row, truth_run.pick_rows
    carried = [p for p in picks if p["success"]]
    assert len(carried) == row["picked"] >= 6, row  # every item carried landed in its bin
    for name in CLASS_OF:
        in_bin = [p for p in carried if p["bin"] == name]
        own = [p for p in in_bin if p["true_class"] == name]
        purity = row[f"purity_{name}"]
        if in_bin:
            assert purity == pytest.approx(len(own) / len(in_bin), abs=1e-12)
        else:
            assert purity is None
        entered = row[f"entered_{name}"]
        assert row[f"recovery_{name}"] == pytest.approx(len(own) / entered, abs=1e-12)
        assert 0.0 <= row[f"recovery_{name}"] <= 1.0


def test_truth_episode_sees_every_item_and_leaves_none_unsure(truth_run):
    row, picks = truth_run.episode_row, truth_run.pick_rows
    assert row["min_class_confidence"] == 0.0
    assert row["left_unsure"] == 0
    assert row["never_detected"] == 0  # truth perception reports every item on the belt
    assert row["empty_picks"] <= row["failed_picks"] == sum(1 for p in picks if not p["success"])


class SoftTruth:
    """Truth perception whose class probabilities are softened: the true class at 0.55, the two
    other materials at 0.225 (an uncertain camera's posterior, with exact positions)."""

    def __init__(self, truth):
        self.truth = truth

    def observe(self, t: float, blind: frozenset[int] = frozenset()) -> list[Detection]:
        out = []
        for det in self.truth.observe(t, blind):
            probs = [0.0] + [0.225] * 3
            probs[max(range(4), key=lambda k: det.probs[k])] = 0.55
            out.append(Detection(det.t, det.x, det.y, tuple(probs), det.true_id))
        return out

    def close(self) -> None:
        self.truth.close()


def soft_episode(cell, threshold: float) -> EpisodeMetrics:
    cfg = config.load(None, **{**SHORT, "items": 6, "duration_s": 5.0})
    with Episode(
        cfg.replace(min_class_confidence=threshold), cell, wrap_perception=SoftTruth
    ) as episode:
        episode.reset()
        episode.run()
    return episode.metrics


def test_unsure_items_are_left_on_the_belt_and_counted(cell):
    metrics = soft_episode(cell, 0.6)
    row = metrics.row()
    assert (row["attempts"], row["picked"]) == (0, 0)
    assert row["missed"] == row["entered"] == 6
    assert row["left_unsure"] == 6  # one track per item (truth tracks carry their item's id)
    assert row["never_detected"] == 0
    assert all(row[f"purity_{c}"] is None for c in CLASS_OF)
    assert all(row[f"recovery_{c}"] == 0.0 for c in CLASS_OF if row[f"entered_{c}"])
    assert metrics.accounting_failures() == []


def test_items_sure_enough_are_offered_as_before(cell):
    metrics = soft_episode(cell, 0.55)
    row = metrics.row()
    assert row["left_unsure"] == 0
    assert row["picked"] >= 4, row
    assert metrics.accounting_failures() == []
