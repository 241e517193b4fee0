"""Counters of one episode and the rows of episodes.csv / picks.csv they produce.

Definitions (thesis 4.1.4 and docs/episode.md):

- `entered` (SI): items that were dropped onto the belt during the episode.
- `picked` (SP): items that the robot placed into a bin (any bin), counted by their true class
  in `picked_<class>`; `wrong_bin` of them landed in a bin of another class.
- `accuracy` = SP / SI.
- `profit_eur`: sum of the values of the items that landed in the bin of their own class. An
  item in the wrong bin earns nothing (its material is not recovered; it is not charged
  either), so a confused class costs the value it would have earned.
- `missed`: items that passed the robot's working space unpicked (the thesis discards them; the
  runner takes them off the belt there); `dropped`: items that fell anywhere but into a bin
  (off the belt, off the cup, beside a bin).
- `mean_cycle_s`: mean time from the start of one pick attempt to the end of its release.
- `thrown_off`: items the robot struck or flung off the belt (`sim.cell.monitors.thrown`: left
  the belt's top area sideways or upstream, or moved faster than 1.5 m/s, while neither held
  nor released over a bin by the cup). Each is also booked where it ends: dropped when it came
  to rest off the belt (in a bin too: only what the cup carries there is picked), missed or
  picked when it stayed on the belt.
- `mujoco_warnings`: MuJoCo's warnings (`data.warning`) raised during the episode, all kinds.
- `energy_mech_j`, `energy_elec_j`: the robot's motor energy over the whole episode, idle time
  included (`sim.cell.monitors.energy`: mechanical = integral of |tau omega|; electrical =
  the regenerative-free estimate); per pick in picks.csv, from the start of the attempt to the
  end of its release, with the pick's distance `travel_m` (the thesis's d: rest -> item -> bin
  in the belt's plane).
- `energy_cost_eur` = electrical energy [kWh] x the configured price; `net_profit_eur` =
  profit_eur - energy_cost_eur.

Accounting identities, true of every finished episode (`accounting_failures` checks them):

- entered = picked + missed + dropped, the three sets disjoint (every item ends in exactly
  one: in a bin, past the robot or at the time cap, or anywhere else);
- entered = entered_paper + entered_plastic + entered_aluminium, and the same for picked;
- wrong_bin <= picked <= attempts - failed_picks (only an item the cup carried and released
  over a bin can be in one);
- thrown_off is a subset of picked | missed | dropped (a thrown item is booked where it ends);
- accuracy = picked / entered.
"""

from __future__ import annotations

from dataclasses import dataclass

from perception.codes import ALUMINIUM, CLASS_NAMES, PAPER, PLASTIC
from sim.cell.monitors.energy import JOULES_PER_KWH

ITEM_CLASSES = (PAPER, PLASTIC, ALUMINIUM)


def class_name(class_id: int | None) -> str:
    """Name of a class id ('paper', ...), 'none' for None or 0."""
    if not class_id:
        return "none"
    return CLASS_NAMES[int(class_id) - 1]


@dataclass(frozen=True)
class PickRecord:
    """One pick attempt (a row of picks.csv)."""

    t_start_s: float
    t_end_s: float
    item_id: int
    true_class: int | None
    predicted_class: int
    bin: int | None
    success: bool
    travel_m: float = 0.0
    energy_mech_j: float = 0.0
    energy_elec_j: float = 0.0

    def row(self) -> dict[str, object]:
        """The picks.csv row of this attempt."""
        return {
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "item_id": self.item_id,
            "true_class": class_name(self.true_class),
            "predicted_class": class_name(self.predicted_class),
            "bin": class_name(self.bin),
            "success": self.success,
            "cycle_s": self.t_end_s - self.t_start_s,
            "travel_m": self.travel_m,
            "energy_mech_j": self.energy_mech_j,
            "energy_elec_j": self.energy_elec_j,
        }


class EpisodeMetrics:
    """Accumulates what happens to the items and the robot during one episode.

    Args:
        values: Value per class id [EUR] (2 paper, 3 plastic, 4 aluminium).
        energy_price: Price of the motors' electrical energy [EUR/kWh].
    """

    def __init__(self, values: dict[int, float], energy_price: float = 0.0):
        self.values = dict(values)
        self.energy_price = float(energy_price)
        self.energy_mech_j = 0.0  # the robot's motor energy over the episode so far [J]
        self.energy_elec_j = 0.0
        self.entered = {c: 0 for c in ITEM_CLASSES}
        self.binned: dict[int, tuple[int, int]] = {}
        self.missed: set[int] = set()
        self.dropped: set[int] = set()
        self.picks: list[PickRecord] = []
        self.thrown_off: set[int] = set()  # items struck or flung off the belt
        # (sim.cell.monitors.thrown.Throw, what the robot was doing)
        self.throws: list[tuple[object, str]] = []
        self.mujoco_warnings = 0  # MuJoCo warnings raised during the episode
        # the same per kind (sim.cell.monitors.mj_warnings)
        self.warning_kinds: dict[str, int] = {}

    def on_entered(self, item_id: int, true_class: int) -> None:
        """An item was dropped onto the belt."""
        self.entered[int(true_class)] += 1

    def on_binned(self, item_id: int, true_class: int, bin_class: int) -> None:
        """An item landed in the bin of `bin_class` (counted once)."""
        self.binned.setdefault(int(item_id), (int(true_class), int(bin_class)))

    def on_missed(self, item_id: int) -> None:
        """An item left the belt unpicked."""
        if item_id not in self.binned:
            self.missed.add(int(item_id))

    def on_dropped(self, item_id: int) -> None:
        """An item fell somewhere other than the belt's end or a bin."""
        if item_id not in self.binned:
            self.dropped.add(int(item_id))

    def on_thrown(self, throw, doing: str = "") -> None:
        """An item was thrown off the belt (`sim.cell.monitors.thrown.Throw`); `doing` says what the
        robot was doing at the time."""
        if throw.item_id not in self.thrown_off:
            self.thrown_off.add(int(throw.item_id))
            self.throws.append((throw, doing))

    def on_warnings(self, by_kind: dict[str, int]) -> None:
        """MuJoCo raised warnings ({kind: count}) since the last call."""
        for kind, n in by_kind.items():
            self.warning_kinds[kind] = self.warning_kinds.get(kind, 0) + int(n)
            self.mujoco_warnings += int(n)

    def on_energy(self, mechanical_j: float, electrical_j: float) -> None:
        """The robot's motor energy since the episode started [J] (totals, not increments)."""
        self.energy_mech_j = float(mechanical_j)
        self.energy_elec_j = float(electrical_j)

    def on_pick(self, record: PickRecord) -> None:
        """A pick attempt finished (successfully or not)."""
        self.picks.append(record)

    @property
    def n_entered(self) -> int:
        return sum(self.entered.values())

    @property
    def n_picked(self) -> int:
        return len(self.binned)

    @property
    def profit(self) -> float:
        """Value of the items in their own class's bin [EUR]."""
        return sum(self.values[t] for t, b in self.binned.values() if t == b)

    def picked_of(self, class_id: int) -> int:
        """Items of true class `class_id` placed into a bin."""
        return sum(1 for t, _ in self.binned.values() if t == class_id)

    def row(self) -> dict[str, object]:
        """The episode's counters as episodes.csv columns (config and timing added by caller)."""
        n_in = self.n_entered
        cycles = [p.t_end_s - p.t_start_s for p in self.picks if p.success]
        return {
            "picked": self.n_picked,
            "picked_paper": self.picked_of(PAPER),
            "picked_plastic": self.picked_of(PLASTIC),
            "picked_aluminium": self.picked_of(ALUMINIUM),
            "wrong_bin": sum(1 for t, b in self.binned.values() if t != b),
            "missed": len(self.missed),
            "accuracy": self.n_picked / n_in if n_in else 0.0,
            "profit_eur": self.profit,
            "mean_cycle_s": sum(cycles) / len(cycles) if cycles else 0.0,
            "entered": n_in,
            "attempts": len(self.picks),
            "failed_picks": sum(1 for p in self.picks if not p.success),
            "dropped": len(self.dropped),
            "entered_paper": self.entered[PAPER],
            "entered_plastic": self.entered[PLASTIC],
            "entered_aluminium": self.entered[ALUMINIUM],
            "mujoco_warnings": self.mujoco_warnings,
            "thrown_off": len(self.thrown_off),
            "energy_mech_j": self.energy_mech_j,
            "energy_elec_j": self.energy_elec_j,
            "energy_cost_eur": self.energy_cost,
            "net_profit_eur": self.profit - self.energy_cost,
        }

    @property
    def energy_cost(self) -> float:
        """The electrical energy's cost at the configured price [EUR]."""
        return self.energy_elec_j / JOULES_PER_KWH * self.energy_price

    def accounting_failures(self) -> list[str]:
        """The accounting identities of the module docstring that do not hold (empty: all do).

        Call once the episode has finished (no item left on the belt)."""
        row = self.row()
        fails = []
        picked, missed, dropped = set(self.binned), self.missed, self.dropped
        if row["entered"] != len(picked) + len(missed) + len(dropped):
            fails.append(
                f"entered {row['entered']} != picked {len(picked)} + missed {len(missed)} "
                f"+ dropped {len(dropped)}"
            )
        for name, a, b in (("picked&missed", picked, missed), ("picked&dropped", picked, dropped)):
            if a & b:
                fails.append(f"{name} overlap: {sorted(a & b)}")
        if missed & dropped:
            fails.append(f"missed&dropped overlap: {sorted(missed & dropped)}")
        for what in ("entered", "picked"):
            parts = sum(row[f"{what}_{c}"] for c in ("paper", "plastic", "aluminium"))
            if parts != row[what]:
                fails.append(f"{what} {row[what]} != sum by class {parts}")
        carried = row["attempts"] - row["failed_picks"]
        if not row["wrong_bin"] <= row["picked"] <= carried:
            fails.append(
                f"not wrong_bin {row['wrong_bin']} <= picked {row['picked']} "
                f"<= carried to a bin {carried}"
            )
        unbooked = self.thrown_off - picked - missed - dropped
        if unbooked:
            fails.append(f"thrown off but never booked: {sorted(unbooked)}")
        n_in = row["entered"]
        if n_in and abs(row["accuracy"] - row["picked"] / n_in) > 1e-12:
            fails.append("accuracy != picked / entered")
        return fails

    def pick_rows(self) -> list[dict[str, object]]:
        """picks.csv rows, in the order the attempts started."""
        return [p.row() for p in sorted(self.picks, key=lambda p: (p.t_start_s, p.item_id))]
