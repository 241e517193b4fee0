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
- `left_on_belt`: items still in play when the episode ended at its horizon (`horizon_s`): on
  the belt, in a cup or falling, booked neither picked, missed nor dropped (0 without a
  horizon, or when the belt was clear before it); `not_arrived`: the flow's items not yet
  dropped then (`n_items` - `entered`).
- `mean_cycle_s`: mean time from the start of one pick attempt to the end of its release.
- `thrown_off`: items the robot struck or flung off the belt (`sim.monitors.thrown`: left
  the belt's top area sideways or upstream, or moved faster than 1.5 m/s, while neither held
  nor released over a bin by the cup). Each is also booked where it ends: dropped when it came
  to rest off the belt (in a bin too: only what the cup carries there is picked), missed or
  picked when it stayed on the belt.
- `mujoco_warnings`: MuJoCo's warnings (`data.warning`) raised during the episode, all kinds.
- `energy_mech_j`, `energy_elec_j`: the robot's motor energy over the whole episode, idle time
  included (`sim.monitors.energy`: mechanical = integral of |tau omega|; electrical =
  the regenerative-free estimate); per pick in picks.csv, from the start of the attempt to the
  end of its release, with the pick's distance `travel_m` (the thesis's d: rest -> item -> bin
  in the belt's plane).
- `energy_cost_eur` = electrical energy [kWh] x the configured price; `net_profit_eur` =
  profit_eur - energy_cost_eur.
- `mass_entered_kg`, `mass_recovered_kg`: the mass of the items that entered and of those in
  the bin of their own class [kg] (each item's own mass, as the world varied its size).

Sorting quality (what a plant judges a sorter by):

- `purity_<class>` (per bin): items of that class in that bin / all items in that bin (picked
  items only: what the cup carried there). An empty bin has no purity: the cell is left empty
  in episodes.csv (None in the row), never 0 or NaN.
- `recovery_<class>` (per class): items of that class in its own bin / items of that class that
  entered. Left empty when no item of the class entered.
- `never_detected`: items that entered and left the belt (picked, missed or dropped) although
  no track was ever attributed to them (`on_detected`). In truth mode a track carries its item's
  id; in camera mode a new track is attributed to the nearest true item within the tracker's
  match radius (`sim.sensing.attribution`: the evaluation's bookkeeping, never the robot's
  knowledge). An undetected item can still be picked: the cup may seal on it next to its target.
- `never_visible` (camera perception): items that passed the camera (their centre reached its
  line at an observation) but of which less than 30 % of the top area was seen at every camera
  observation (`sim.monitors.visibility`: covered by other items); None, an empty cell, in truth
  perception, which renders no camera.
- `empty_picks`: pick attempts whose cup never sealed, so carried no item (`PickRecord.sealed`).
- `left_unsure`: tracks the confidence rule (`min_class_confidence`,
  `sim.sensing.confidence`) kept from the decision manager until they went past the robot
  unpicked (past its reach, or their item missed) or were still tracked when the episode
  ended: their most probable class was less probable than the threshold. It counts tracks, the
  cell's belief of items (in camera mode a phantom or a split item counts too). 0 in truth mode
  (certain classes) and at the default threshold 0.

Accounting identities, true of every finished episode (`accounting_failures` checks them):

- entered = picked + missed + dropped + left_on_belt, the four sets disjoint (every item ends
  in exactly one: in a bin, past the robot or at the time cap, anywhere else, or still in play
  at the horizon); n_items = entered + not_arrived, not_arrived >= 0;
- entered = entered_paper + entered_plastic + entered_aluminium, and the same for picked;
- wrong_bin <= picked <= attempts - failed_picks (only an item the cup carried and released
  over a bin can be in one);
- thrown_off is a subset of picked | missed | dropped (a thrown item is booked where it ends);
- accuracy = picked / entered;
- 0 <= purity_c <= 1, defined exactly when bin c holds an item; 0 <= recovery_c <= 1, defined
  exactly when an item of class c entered; sum over bins of purity_c x (items in bin c) =
  sum over classes of recovery_c x entered_c = picked - wrong_bin (the items in their own bin);
- empty_picks <= failed_picks (an attempt whose cup never sealed carried nothing to a bin: no
  empty pick is a success);
- every item a track was attributed to entered, so never_detected <= entered; every item that
  passed the camera entered, so never_visible <= entered.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from perception.codes import ALUMINIUM, PAPER, PLASTIC, THESIS_MATERIALS, Materials
from sim.monitors.energy import JOULES_PER_KWH
from sim.monitors.visibility import VISIBLE_SHARE
from sim.results.pick_log import PickLog, PickRecord, RowSink

if TYPE_CHECKING:
    from sim.monitors.thrown import Throw

ITEM_CLASSES = (PAPER, PLASTIC, ALUMINIUM)
"""The thesis's material classes (a catalogue's materials may be others)."""


def class_name(class_id: int | None, materials: Materials = THESIS_MATERIALS) -> str:
    """Name of a class id ('paper', ...), 'none' for None or 0."""
    return materials.name_of(class_id)


class EpisodeMetrics:
    """Accumulates what happens to the items and the robot during one episode.

    Args:
        values: Value per material class id [EUR] (2 paper, 3 plastic, 4 aluminium).
        energy_price: Price of the motors' electrical energy [EUR/kWh].
        materials: The cell's materials (the columns `picked_<name>` ... follow them).
        item_values: Value of single items [EUR] ({item id: EUR}) where it is not their
            class's (an item type's own value, a price per kg; `[values]`).
        item_masses: Each item's mass as varied [kg] ({item id: kg}), for `mass_entered_kg` and
            `mass_recovered_kg`; None: not known (the columns are left empty).
        n_items: The flow's items (`not_arrived` counts those not dropped); None: not known
            (the column is left empty).
    """

    def __init__(
        self,
        values: dict[int, float],
        energy_price: float = 0.0,
        materials: Materials = THESIS_MATERIALS,
        item_values: dict[int, float] | None = None,
        item_masses: dict[int, float] | None = None,
        n_items: int | None = None,
    ):
        self.values = dict(values)
        self.item_masses = None if item_masses is None else dict(item_masses)
        self.n_items = n_items
        self.left_on_belt: set[int] = set()  # in play when the horizon ended the episode
        self.materials = materials
        self.item_values = dict(item_values or {})
        self.energy_price = float(energy_price)
        self.energy_mech_j = 0.0  # the robot's motor energy over the episode so far [J]
        self.energy_elec_j = 0.0
        self.entered = {c: 0 for c in materials.ids}
        self.entered_ids: set[int] = set()
        self.detected: set[int] = set()  # items some track was attributed to
        self.left_unsure = 0  # tracks the confidence rule kept from the decision manager
        # camera perception: each item's largest visible fraction of its top area at an
        # observation, and the items that passed the camera; None: not measured (truth)
        self.best_visible: dict[int, float] | None = None
        self.passed_camera: set[int] = set()
        self.binned: dict[int, tuple[int, int]] = {}
        self.missed: set[int] = set()
        self.dropped: set[int] = set()
        self.pick_log = PickLog(materials)
        self.thrown_off: set[int] = set()  # items struck or flung off the belt
        # (sim.monitors.thrown.Throw, what the robot was doing)
        self.throws: list[tuple[Throw, str]] = []
        self.mujoco_warnings = 0  # MuJoCo warnings raised during the episode
        # the same per kind (sim.monitors.mj_warnings)
        self.warning_kinds: dict[str, int] = {}

    def on_entered(self, item_id: int, true_class: int) -> None:
        """An item was dropped onto the belt."""
        self.entered[int(true_class)] += 1
        self.entered_ids.add(int(item_id))

    def on_detected(self, item_id: int) -> None:
        """A new track was attributed to the item `item_id` (`sim.sensing.attribution`)."""
        self.detected.add(int(item_id))

    def on_visibility(self, fractions: dict[int, float], passed=()) -> None:
        """One camera observation (`sim.monitors.visibility.Sighting`): the visible fraction
        of the top area of each item near the camera, by flow id, and the items that have
        passed the camera. The first call, even with nothing seen, starts `never_visible`."""
        if self.best_visible is None:
            self.best_visible = {}
        best = self.best_visible
        for item_id, fraction in fractions.items():
            best[int(item_id)] = max(float(fraction), best.get(int(item_id), 0.0))
        self.passed_camera.update(int(i) for i in passed)

    def on_left_unsure(self, n_tracks: int = 1) -> None:
        """`n_tracks` tracks left the tracker while the confidence rule kept them back."""
        self.left_unsure += int(n_tracks)

    def on_binned(self, item_id: int, true_class: int, bin_class: int) -> None:
        """An item landed in the bin of `bin_class` (counted once)."""
        self.binned.setdefault(int(item_id), (int(true_class), int(bin_class)))

    def on_missed(self, item_id: int) -> None:
        """An item left the belt unpicked."""
        if item_id not in self.binned:
            self.missed.add(int(item_id))

    def on_left_on_belt(self, item_id: int) -> None:
        """An item was still in play when the episode ended at its horizon."""
        if item_id not in self.binned:
            self.left_on_belt.add(int(item_id))

    def on_dropped(self, item_id: int) -> None:
        """An item fell somewhere other than the belt's end or a bin."""
        if item_id not in self.binned:
            self.dropped.add(int(item_id))

    def on_thrown(self, throw, doing: str = "") -> None:
        """An item was thrown off the belt (`sim.monitors.thrown.Throw`); `doing` says what the
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

    def on_pick_started(self, robot: int, t_start_s: float) -> None:
        """Robot `robot` started a pick attempt at sim time `t_start_s` [s]."""
        self.pick_log.started(robot, t_start_s)

    def on_pick(self, record: PickRecord) -> None:
        """A pick attempt finished (successfully or not)."""
        self.pick_log.add(record)

    def stream_picks(self, sink: RowSink) -> None:
        """Hand picks.csv's rows to `sink` as they come, in order, instead of keeping them
        (`sim.results.pick_log`); call `finish_picks` once the episode ends or stops."""
        self.pick_log.stream_to(sink)

    def finish_picks(self) -> None:
        """The episode ended or stopped: the streamed rows still held go to the sink."""
        self.pick_log.finish()

    @property
    def picks(self) -> list[PickRecord]:
        """The attempts in the order they ended (empty when they are streamed)."""
        return self.pick_log.kept or []

    @property
    def n_entered(self) -> int:
        return sum(self.entered.values())

    @property
    def n_picked(self) -> int:
        return len(self.binned)

    @property
    def profit(self) -> float:
        """Value of the items in their own class's bin [EUR]."""
        worth = self.item_values
        return sum(worth.get(i, self.values[t]) for i, (t, b) in self.binned.items() if t == b)

    def status_line(self, t: float) -> str:
        """One line for a progress bar at sim time `t` [s]."""
        return (
            f"t {t:6.1f} s  entered {self.n_entered}  picked {self.n_picked}  "
            f"missed {len(self.missed)}  profit {self.profit:.2f} EUR"
        )

    def picked_of(self, class_id: int) -> int:
        """Items of true class `class_id` placed into a bin."""
        return sum(1 for t, _ in self.binned.values() if t == class_id)

    def in_bin(self, bin_class: int) -> int:
        """Items placed into the bin of `bin_class`, whatever their class."""
        return sum(1 for _, b in self.binned.values() if b == bin_class)

    def in_own_bin(self, class_id: int) -> int:
        """Items of true class `class_id` placed into their own class's bin."""
        return sum(1 for t, b in self.binned.values() if t == b == class_id)

    def purity(self, bin_class: int) -> float | None:
        """Share of the items in the bin of `bin_class` that are of that class; None: empty."""
        n = self.in_bin(bin_class)
        return self.in_own_bin(bin_class) / n if n else None

    def recovery(self, class_id: int) -> float | None:
        """Share of the items of `class_id` that entered and ended in their own bin; None when
        none entered."""
        n = self.entered[class_id]
        return self.in_own_bin(class_id) / n if n else None

    @property
    def n_never_detected(self) -> int:
        """Items that left the belt (picked, missed, dropped) without a track attributed."""
        left = set(self.binned) | self.missed | self.dropped
        return len(left - self.detected)

    @property
    def n_never_visible(self) -> int | None:
        """Items that passed the camera with less than `VISIBLE_SHARE` of their top area
        seen at every observation; None when visibility was not measured (truth perception)."""
        if self.best_visible is None:
            return None
        best = self.best_visible
        return sum(1 for i in self.passed_camera if best.get(i, 0.0) < VISIBLE_SHARE)

    @property
    def n_empty_picks(self) -> int:
        """Pick attempts whose cup never sealed."""
        return self.pick_log.empty

    def row(self) -> dict[str, Any]:
        """The episode's counters as episodes.csv columns (config and timing added by caller)."""
        n_in = self.n_entered
        log = self.pick_log
        names = dict(zip(self.materials.ids, self.materials.names, strict=True))
        return {
            "picked": self.n_picked,
            **{f"picked_{names[c]}": self.picked_of(c) for c in self.materials.ids},
            "wrong_bin": sum(1 for t, b in self.binned.values() if t != b),
            "missed": len(self.missed),
            "accuracy": self.n_picked / n_in if n_in else 0.0,
            "profit_eur": self.profit,
            "mean_cycle_s": log.success_cycle_s / log.success_cycles if log.success_cycles else 0.0,
            "entered": n_in,
            "attempts": log.attempts,
            "failed_picks": log.failed,
            "dropped": len(self.dropped),
            "left_on_belt": len(self.left_on_belt),
            "not_arrived": None if self.n_items is None else self.n_items - n_in,
            **{f"entered_{names[c]}": self.entered[c] for c in self.materials.ids},
            "mujoco_warnings": self.mujoco_warnings,
            "thrown_off": len(self.thrown_off),
            "energy_mech_j": self.energy_mech_j,
            "energy_elec_j": self.energy_elec_j,
            "energy_cost_eur": self.energy_cost,
            "net_profit_eur": self.profit - self.energy_cost,
            **self.quality_row(),
            **self.mass_row(),
        }

    def mass_row(self) -> dict[str, float | None]:
        """`mass_entered_kg` (the items that entered) and `mass_recovered_kg` (those in their own
        class's bin) [kg]; None without the items' masses."""
        mass = self.item_masses
        if mass is None:
            return {"mass_entered_kg": None, "mass_recovered_kg": None}
        own = [i for i, (t, b) in self.binned.items() if t == b]
        return {
            "mass_entered_kg": sum(mass[i] for i in sorted(self.entered_ids)),
            "mass_recovered_kg": sum(mass[i] for i in sorted(own)),
        }

    def line_row(
        self, sim_s: float, energy_elec_j: Sequence[float], coordination: str
    ) -> dict[str, Any]:
        """A line's columns: robots, coordination and each robot's `robot_row` (its motors'
        electrical energy `energy_elec_j[k]` [J], upstream first; `sim.results.outputs.
        line_columns`); `robots` alone for one robot. `sim_s` is the episode's length [s]."""
        if len(energy_elec_j) <= 1:
            return {"robots": len(energy_elec_j)}
        out: dict[str, Any] = {"robots": len(energy_elec_j), "coordination": coordination}
        for k, energy in enumerate(energy_elec_j):
            out |= self.robot_row(k, sim_s, energy)
        return out

    def robot_row(self, robot: int, sim_s: float, energy_elec_j: float) -> dict[str, Any]:
        """A line's columns of one robot (`robot<k>_...`): its items binned, binned per minute,
        utilisation (the share of the episode its picks took, from start to release) and its
        motors' electrical energy [J]."""
        totals = self.pick_log.robots.get(robot)
        binned, busy = (0, 0.0) if totals is None else (totals.binned, totals.busy_s)
        key = f"robot{robot}_"
        return {
            key + "picked": binned,
            key + "picks_per_min": binned / (sim_s / 60.0) if sim_s > 0 else 0.0,
            key + "utilisation": busy / sim_s if sim_s > 0 else 0.0,
            key + "energy_elec_j": float(energy_elec_j),
        }

    def quality_row(self) -> dict[str, Any]:
        """The sorting-quality columns (purity and recovery are None where undefined)."""
        row: dict[str, Any] = {}
        for c in self.materials.ids:
            row[f"purity_{self.materials.name_of(c)}"] = self.purity(c)
        for c in self.materials.ids:
            row[f"recovery_{self.materials.name_of(c)}"] = self.recovery(c)
        row["never_detected"] = self.n_never_detected
        row["never_visible"] = self.n_never_visible
        row["empty_picks"] = self.n_empty_picks
        row["left_unsure"] = self.left_unsure
        return row

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
        left = self.left_on_belt
        if row["entered"] != len(picked) + len(missed) + len(dropped) + len(left):
            fails.append(
                f"entered {row['entered']} != picked {len(picked)} + missed {len(missed)} "
                f"+ dropped {len(dropped)} + left_on_belt {len(left)}"
            )
        pairs = (
            ("picked&missed", picked, missed),
            ("picked&dropped", picked, dropped),
            ("missed&dropped", missed, dropped),
            ("left_on_belt&booked", left, picked | missed | dropped),
        )
        for name, a, b in pairs:
            if a & b:
                fails.append(f"{name} overlap: {sorted(a & b)}")
        not_arrived = row["not_arrived"]
        if not_arrived is not None and not_arrived < 0:
            fails.append(f"not_arrived {not_arrived} < 0: more entered than the flow's items")
        for what in ("entered", "picked"):
            parts = sum(row[f"{what}_{c}"] for c in self.materials.names)
            if parts != row[what]:
                fails.append(f"{what} {row[what]} != sum by class {parts}")
        carried = row["attempts"] - row["failed_picks"]
        if not row["wrong_bin"] <= row["picked"] <= carried:
            fails.append(
                f"not wrong_bin {row['wrong_bin']} <= picked {row['picked']} "
                f"<= carried to a bin {carried}"
            )
        unbooked = self.thrown_off - picked - missed - dropped - left
        if unbooked:
            fails.append(f"thrown off but never booked: {sorted(unbooked)}")
        n_in = row["entered"]
        if n_in and abs(row["accuracy"] - row["picked"] / n_in) > 1e-12:
            fails.append("accuracy != picked / entered")
        return fails + self._quality_failures(row) + self._visibility_failures(row)

    def _visibility_failures(self, row: dict[str, Any]) -> list[str]:
        """The identities of `never_visible` that do not hold."""
        fails = []
        unknown = self.passed_camera - self.entered_ids
        if unknown:
            fails.append(f"passed the camera but never entered: {sorted(unknown)}")
        never_visible = row["never_visible"]
        if never_visible is not None and not 0 <= never_visible <= row["entered"]:
            fails.append(f"never_visible {never_visible} outside 0..{row['entered']}")
        return fails

    def _quality_failures(self, row: dict[str, Any]) -> list[str]:
        """The sorting-quality identities of the module docstring that do not hold."""
        fails = []
        own = row["picked"] - row["wrong_bin"]
        by_bin = by_class = 0.0
        for c in self.materials.ids:
            name = self.materials.name_of(c)
            purity, recovery = row[f"purity_{name}"], row[f"recovery_{name}"]
            if (purity is None) != (self.in_bin(c) == 0):
                fails.append(f"purity_{name} {purity} but {self.in_bin(c)} items in the bin")
            elif purity is not None and not 0.0 <= purity <= 1.0:
                fails.append(f"purity_{name} {purity} outside [0, 1]")
            if (recovery is None) != (self.entered[c] == 0):
                fails.append(f"recovery_{name} {recovery} but {self.entered[c]} entered")
            elif recovery is not None and not 0.0 <= recovery <= 1.0:
                fails.append(f"recovery_{name} {recovery} outside [0, 1]")
            by_bin += (purity or 0.0) * self.in_bin(c)
            by_class += (recovery or 0.0) * self.entered[c]
        for what, total in (("purity", by_bin), ("recovery", by_class)):
            if abs(total - own) > 1e-9:
                fails.append(f"{what}-weighted items {total:g} != picked - wrong_bin {own}")
        if self.pick_log.sealed_failures:
            fails.append("a pick whose cup never sealed counted as a success")
        if not row["empty_picks"] <= row["failed_picks"]:
            fails.append(f"empty_picks {row['empty_picks']} > failed_picks {row['failed_picks']}")
        unknown = self.detected - self.entered_ids
        if unknown:
            fails.append(f"detected but never entered: {sorted(unknown)}")
        if not 0 <= row["never_detected"] <= row["entered"]:
            fails.append(f"never_detected {row['never_detected']} outside 0..{row['entered']}")
        return fails

    def pick_rows(self) -> list[dict[str, Any]]:
        """picks.csv rows, in the order the attempts started."""
        return self.pick_log.rows()
