"""MuJoCo's own warnings (`data.warning`), counted while a simulation runs.

MuJoCo does not raise when the simulation goes wrong: it counts each kind of trouble in
`data.warning[kind].number` (an unstable state it had to reset, a contact or constraint buffer
that overflowed, a bad inertia, a non-finite control), prints the first one to stderr and
`MUJOCO_LOG.TXT`, and carries on. The counts accumulate until `mj_resetData` (which
`sim.cell.cell.Cell.reset` calls). `WarningCounter` takes them every few milliseconds of
simulated time and reports what is new, so an episode can count them into `episodes.csv`.
"""

from __future__ import annotations

import warnings

import mujoco
import numpy as np

KINDS: tuple[str, ...] = tuple(
    name.removeprefix("mjWARN_").lower()
    for name in sorted(
        (n for n in dir(mujoco.mjtWarning) if n.startswith("mjWARN_")),
        key=lambda n: int(getattr(mujoco.mjtWarning, n)),
    )
)
"""Names of MuJoCo's warning kinds, in the order of `data.warning` ("inertia",
"contactfull", "cnstrfull", "badqpos", "badqvel", "badqacc", "badctrl")."""


class MujocoWarning(RuntimeWarning):
    """Python warning issued when MuJoCo raised warnings during a simulation."""


class WarningCounter:
    """New MuJoCo warnings since the last look.

    Each look takes the counts out of `data.warning` (sets them back to zero), so what it
    reports is exactly what happened since the last look, also across the resets MuJoCo
    makes itself when a state blows up (`mj_resetData`, then the warning counted once), which
    a comparison with the last totals would miss when the count comes back the same. MuJoCo
    prints the first warning of a kind after each look that took some.

    Args:
        data: The simulation's data (warnings already counted in it are taken as seen).
    """

    def __init__(self, data: mujoco.MjData):
        self.data = data
        self._take()
        self.total = 0
        self.by_kind = dict.fromkeys(KINDS, 0)

    def _take(self) -> np.ndarray:
        numbers = self.data.warning.number  # a view of every kind's count
        counts = numbers.astype(np.int64)
        if counts.any():
            numbers[:] = 0
        return counts

    def update(self) -> dict[str, int]:
        """The warnings raised since the last call, per kind (empty when none: the usual
        case); a Python `MujocoWarning` names them when there are any."""
        new = self._take()
        if not new.any():
            return {}
        out = {KINDS[i]: int(n) for i, n in enumerate(new) if n}
        for kind, n in out.items():
            self.by_kind[kind] += n
            self.total += n
        t = float(self.data.time)
        text = ", ".join(f"{k} x{n}" for k, n in out.items())
        warnings.warn(f"MuJoCo warnings by t = {t:.3f} s: {text}", MujocoWarning, stacklevel=2)
        return out
