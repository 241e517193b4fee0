"""Perfect perception (`--perception truth`, the fast path): no rendering; every period, each
item past the camera line is reported where the simulation has it, with its true class as a
certainty (an item that slips on the belt is still tracked exactly). The camera's source with
the same interface is `sim.sensing.perception.CameraPerception`; this module imports none of
its rendering or learning.
"""

from __future__ import annotations

from perception.codes import N_STATES
from sim.cell.items import Items
from sim.flow.config import X_CAMERA
from sim.flow.generator import Flow
from sim.sensing.tracking import Detection

ON_BELT_TOL_M = 0.04
"""An item whose centre is higher than its resting height plus this is not on the belt [m]: held
by the cup or thrown. An item lying partly over a flat neighbour (a crushed can, 1-2 cm) is
still on the belt."""


def one_hot(class_id: int, n_states: int = N_STATES) -> tuple[float, ...]:
    """Class probabilities (void, *materials) of a certain class."""
    probs = [0.0] * n_states
    probs[int(class_id) - 1] = 1.0
    return tuple(probs)


class TruthPerception:
    """True items as they cross the camera line (no rendering)."""

    name = "truth"

    def __init__(self, items: Items, flow: Flow, belt_speed: float, period_s: float):
        self.items, self.pool, self.flow = items, items.pool, flow
        self.n_states = items.pool.catalogue.materials.n_states
        self.half_width = items.pool.belt.geometry.y_half
        """Half the belt's width [m] (the model's): items beyond it are off the belt."""
        self.rows = self.unobserved = 0
        self.seen: set[int | None] = set()  # the items reported, the camera working
        self.unseen: set[int | None] = set()  # items that crossed the line while it was out

    def observe(self, t: float, blind: frozenset[int] = frozenset()) -> list[Detection]:
        """Every item on the belt past the camera line, where the simulation has it now; none
        while the camera (0) is in `blind` (an outage), and never an item that crossed the line
        during one (the camera line sees an item as it crosses)."""
        self.rows += 1
        out = []
        for slot in self.items.active_slots():
            item_id = int(self.pool.item_ids[slot])
            x, y, z = self.items.position(slot)
            resting = -0.05 < z < self.pool.item_type(int(slot)).rest_height + ON_BELT_TOL_M
            if X_CAMERA <= x and resting and abs(y) <= self.half_width:
                cls = int(self.flow.class_id[item_id])
                probs = one_hot(cls, self.n_states)
                out.append(Detection(t, float(x), float(y), probs, true_id=item_id))
        if 0 in blind:
            self.unseen |= {d.true_id for d in out} - self.seen
            return []
        if self.unseen:
            out = [d for d in out if d.true_id not in self.unseen]
        self.seen.update(d.true_id for d in out)
        return out

    def close(self) -> None:
        """Nothing to free."""
