"""`learned`: a pick-order policy trained on `sortsim/PickOrder-v0`, run with numpy alone.

The policy scores each of the K most urgent candidates (`planner.decision.slot_features`) with a
linear function of its features and a few ratios of them, and picks the best; it waits when
the best score is below a learned waiting score. Its weights are trained by the cross-entropy
method on planner-level belts (`sim.evaluation.policy_training`, `sortsim train`) and shipped
as a small JSON file (`planner/decision/managers/data/learned_policy.json`). A linear scorer can
express FIFO (weight on the time left), greedy on value per second and mixtures of them;
training finds the mixture that earns most on the training belts.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem
from planner.decision.slot_features import (
    FEATURES,
    N_FEATURES,
    choice_for,
    observe,
    slot_candidates,
)
from planner.errors import PlannerInputError

POLICY_FILE = Path(__file__).with_name("data") / "learned_policy.json"
"""The shipped weights."""
DERIVED_TERMS = ("value_per_reach_s", "slack_s")
TERMS = (*FEATURES[1:], *DERIVED_TERMS)
"""What the score is linear in: the slot features (but `present`), expected value over the time
to reach it (+0.3 s), and the slack (time left minus time to reach) [s]."""


def terms(obs: np.ndarray, k_slots: int) -> np.ndarray:
    """(k_slots, len(TERMS)) score terms of an observation."""
    slots = obs.reshape(k_slots, N_FEATURES)
    f = {name: slots[:, i] for i, name in enumerate(FEATURES)}
    reach = f["time_to_reach_s"]
    derived = {
        "value_per_reach_s": f["expected_value_eur"] / (reach + 0.3),
        "slack_s": f["time_left_s"] - reach,
    }
    return np.stack([f[n] if n in f else derived[n] for n in TERMS], axis=1)


@dataclass(frozen=True)
class SlotPolicy:
    """Linear slot scores and a waiting score.

    Attributes:
        weights: One weight per entry of TERMS.
        wait_score: Score of waiting; the best candidate is picked when it scores above it.
        k_slots: Candidates scored per decision.
    """

    weights: tuple[float, ...]
    wait_score: float
    k_slots: int = 8

    def __post_init__(self):
        if len(self.weights) != len(TERMS) or not all(math.isfinite(w) for w in self.weights):
            raise PlannerInputError("weights", f"{len(TERMS)} finite numbers", self.weights)
        if not math.isfinite(self.wait_score):
            raise PlannerInputError("wait_score", "a finite number", self.wait_score)
        if not (isinstance(self.k_slots, int) and 1 <= self.k_slots <= 64):
            raise PlannerInputError("k_slots", "an integer 1..64", self.k_slots)

    @classmethod
    def from_vector(cls, vector: np.ndarray, k_slots: int = 8) -> SlotPolicy:
        """The policy of a parameter vector (weights, then the waiting score)."""
        v = [float(x) for x in vector]
        return cls(tuple(v[: len(TERMS)]), v[len(TERMS)], k_slots)

    def vector(self) -> np.ndarray:
        """The parameter vector (weights, then the waiting score)."""
        return np.array([*self.weights, self.wait_score])

    def act(self, obs: np.ndarray, mask: np.ndarray) -> int:
        """The action for an observation and its mask (k_slots = wait)."""
        scores = terms(obs, self.k_slots) @ np.asarray(self.weights)
        scores = np.where(mask[: self.k_slots], scores, -np.inf)
        best = int(np.argmax(scores))
        return best if scores[best] > self.wait_score else self.k_slots

    def to_json(self) -> str:
        """The policy as JSON text (what `load` reads)."""
        data = {
            "terms": list(TERMS),
            "weights": list(self.weights),
            "wait_score": self.wait_score,
            "k_slots": self.k_slots,
        }
        return json.dumps(data, indent=2) + "\n"

    def save(self, path: Path) -> None:
        """Write the policy as JSON, through a temporary file and a rename (never half a file)."""
        path = Path(path)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        try:
            tmp.write_text(self.to_json(), encoding="utf-8")
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)

    @classmethod
    def load(cls, path: str | Path = POLICY_FILE) -> SlotPolicy:
        """Read a policy written by `save`; refused in one line when unusable."""
        try:
            data = json.loads(Path(path).read_text(encoding="utf-8"))
            if data["terms"] != list(TERMS):
                raise PlannerInputError(f"policy {path}", f"terms {list(TERMS)}", data["terms"])
            return cls(tuple(data["weights"]), float(data["wait_score"]), int(data["k_slots"]))
        except PlannerInputError:
            raise
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise PlannerInputError(
                f"policy {path}", "a readable JSON policy written by sortsim train", str(exc)
            ) from None


class LearnedPlanner:
    """The trained slot policy as a decision manager."""

    name = "learned"

    def __init__(self, policy: SlotPolicy | None = None, policy_file: str | None = None):
        self.policy = policy if policy is not None else SlotPolicy.load(policy_file or POLICY_FILE)

    def reset(self) -> None:
        """Stateless."""

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """The candidate the policy scores best, or None to wait."""
        k = self.policy.k_slots
        cands = slot_candidates(items, robot, context, k)
        if not cands:
            return None
        obs, mask = observe(cands, robot.time, k)
        return choice_for(self.policy.act(obs, mask), cands, k)
