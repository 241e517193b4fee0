"""Where on the belt the cup can meet an item: for each y, the x interval inside the workspace.

Items move along +x, so an item at y enters the window at `x_entry(y)` and leaves it at
`x_exit(y)`; the planners use that to know when an item is lost. The window is a table over y
(linear interpolation), built from a disc or from the delta's inverse kinematics at the pick
height.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np

from planner.errors import PlannerInputError


@dataclass(frozen=True, eq=False)
class ReachWindow:
    """Reachable x interval per belt y at the pick height.

    Attributes:
        y: (K,) increasing y samples [m].
        x_entry: (K,) upstream edge of the window at each y [m] (nan where unreachable).
        x_exit: (K,) downstream edge at each y [m] (nan where unreachable).
        pick_z: Height of the TCP when it meets an item [m].
    """

    y: np.ndarray
    x_entry: np.ndarray
    x_exit: np.ndarray
    pick_z: float = 0.02
    # Set by __post_init__: the samples as plain lists and the memo of `bounds`.
    _ys: list[float] = field(init=False, repr=False)
    _lo: list[float] = field(init=False, repr=False)
    _hi: list[float] = field(init=False, repr=False)
    _bounds_at: dict[float, tuple[float, float] | None] = field(init=False, repr=False)

    def __post_init__(self):
        y = np.asarray(self.y, dtype=float)
        if y.ndim != 1 or y.size < 2 or np.any(np.diff(y) <= 0):
            raise PlannerInputError("y", "at least 2 increasing samples [m]", y.size)
        if np.shape(self.x_entry) != y.shape or np.shape(self.x_exit) != y.shape:
            raise PlannerInputError("x_entry, x_exit", "arrays shaped like y")
        if not math.isfinite(self.pick_z):
            raise PlannerInputError("pick_z", "a finite height [m]", self.pick_z)
        # Plain lists: bounds() is called for every item at every decision, and scalar
        # np.interp costs several microseconds a call.
        object.__setattr__(self, "_ys", [float(v) for v in y])
        object.__setattr__(self, "_lo", [float(v) for v in np.asarray(self.x_entry, float)])
        object.__setattr__(self, "_hi", [float(v) for v in np.asarray(self.x_exit, float)])
        # An item keeps its y along the belt: bounds are asked for the same y again and again.
        object.__setattr__(self, "_bounds_at", {})

    @classmethod
    def disc(cls, radius: float = 0.565, pick_z: float = 0.02, samples: int = 401) -> ReachWindow:
        """A disc of `radius` [m] about the world origin (the robot's base centre)."""
        if not (math.isfinite(radius) and radius > 0.0):
            raise PlannerInputError("radius", "a finite radius > 0 [m]", radius)
        y = np.linspace(-radius, radius, samples)
        half = np.sqrt(np.maximum(radius**2 - y**2, 0.0))
        return cls(y, -half, half, pick_z)

    def shifted(self, dx: float) -> ReachWindow:
        """The same window moved `dx` [m] along the belt (the window of a robot of a line whose
        base stands `dx` downstream of this one's)."""
        if not math.isfinite(dx):
            raise PlannerInputError("dx", "a finite shift [m]", dx)
        x_entry = np.asarray(self.x_entry, float) + dx
        x_exit = np.asarray(self.x_exit, float) + dx
        return ReachWindow(np.asarray(self.y, float), x_entry, x_exit, self.pick_z)

    @classmethod
    def from_reachable(
        cls, reachable, pick_z: float, extent: float = 0.7, samples: int = 161, step: float = 0.002
    ) -> ReachWindow:
        """A window sampled from a vectorised test `reachable((N, 3) points) -> (N,) bool`.

        Args:
            reachable: Workspace test (e.g. `lambda p: kinematics.reachable_mask(geom, p)`).
            pick_z: Height of the TCP at the pick [m].
            extent: Half size of the square searched about the origin [m].
            step: x resolution of the search [m]; the edges are conservative by up to it.
        """
        y = np.linspace(-extent, extent, samples)
        x = np.arange(-extent, extent + step / 2, step)
        gx, gy = np.meshgrid(x, y)
        pts = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, pick_z)])
        ok = np.asarray(reachable(pts), dtype=bool).reshape(gx.shape)
        entry = np.full(samples, np.nan)
        exit_ = np.full(samples, np.nan)
        for k in range(samples):
            inside = np.flatnonzero(ok[k])
            if inside.size:
                entry[k], exit_[k] = x[inside[0]], x[inside[-1]]
        return cls(y, entry, exit_, pick_z)

    def bounds(self, y: float) -> tuple[float, float] | None:
        """(x_entry, x_exit) at `y` [m], or None when no x at that y is reachable."""
        memo = self._bounds_at
        try:
            return memo[y]
        except KeyError:
            pass
        if len(memo) > 4096:
            memo.clear()
        out = memo[y] = self._bounds(y)
        return out

    def _bounds(self, y: float) -> tuple[float, float] | None:
        ys = self._ys
        if not ys[0] <= y <= ys[-1]:
            return None
        k = min(max(bisect.bisect_right(ys, y) - 1, 0), len(ys) - 2)
        f = (y - ys[k]) / (ys[k + 1] - ys[k])
        lo = self._lo[k] + f * (self._lo[k + 1] - self._lo[k])
        hi = self._hi[k] + f * (self._hi[k + 1] - self._hi[k])
        if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
            return None
        return lo, hi

    def contains(self, x: float, y: float) -> bool:
        """Whether the cup can meet an item at (x, y)."""
        b = self.bounds(y)
        return b is not None and b[0] <= x <= b[1]
