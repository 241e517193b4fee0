"""The belt's observation grid: 5 stripes across the belt, one row per observation period.

Convention shared with the flow generator and the ground truth: row k is the belt material in
the band [x_line - vT/2, x_line + vT/2) at time t_k = k T (v belt speed [m/s], T observation
period [s], x_line the camera's line along the belt), so every belt point is observed exactly
once. Stripe j (0..n-1) covers y in [y_min + j w, y_min + (j + 1) w), w = belt width / n, stripe
0 on the -y side. A cell is w x vT.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from perception.errors import PerceptionInputError


@dataclass(frozen=True)
class BeltGrid:
    """Stripes and rows on the belt plane (world frame, +x downstream).

    Attributes:
        x_line: The camera's line along the belt [m].
        y_min: The belt's -y edge [m].
        y_max: The belt's +y edge [m].
        n_stripes: Stripes across the belt.
        period_s: Observation period T [s].
    """

    x_line: float = -1.48
    y_min: float = -0.4
    y_max: float = 0.4
    n_stripes: int = 5
    period_s: float = 0.5

    def __post_init__(self) -> None:
        if not np.isfinite(self.x_line):
            raise PerceptionInputError("grid.x_line", "a finite number [m]", self.x_line)
        if not self.y_max > self.y_min:
            raise PerceptionInputError("grid.y_max", f"> y_min = {self.y_min} m", self.y_max)
        if not 1 <= self.n_stripes <= 64:
            raise PerceptionInputError("grid.n_stripes", "1..64", self.n_stripes)
        if not 0.0 < self.period_s <= 10.0:
            raise PerceptionInputError("grid.period_s", "(0, 10] s", self.period_s)

    @property
    def stripe_width(self) -> float:
        """Width of a stripe [m]."""
        return (self.y_max - self.y_min) / self.n_stripes

    def stripe_edges(self) -> np.ndarray:
        """(n_stripes + 1,) y of the stripe boundaries [m], from the -y edge."""
        return self.y_min + self.stripe_width * np.arange(self.n_stripes + 1)

    def row_pitch(self, speed: float) -> float:
        """Length of a row along the belt [m] at belt speed `speed` [m/s]."""
        if not 0.0 < speed <= 5.0:
            raise PerceptionInputError("belt speed", "(0, 5] m/s", speed)
        return speed * self.period_s

    def row_of_time(self, t: float) -> int:
        """Row index k of the observation nearest to time `t` [s]."""
        return int(np.floor(t / self.period_s + 0.5))

    def band(self, speed: float, t: float | None = None) -> tuple[float, float]:
        """[x_lo, x_hi) [m] of the current row's material at time `t` [s].

        At t = t_k the band is centred on the camera line; at another time it has moved on with
        the belt by v (t - t_k). None means t = t_k.
        """
        pitch = self.row_pitch(speed)
        shift = 0.0 if t is None else speed * (t - self.row_of_time(t) * self.period_s)
        return self.x_line - 0.5 * pitch + shift, self.x_line + 0.5 * pitch + shift

    def cell_area(self, speed: float) -> float:
        """Area of a cell [m^2]."""
        return self.stripe_width * self.row_pitch(speed)

    def cell_corners(self, speed: float, t: float | None = None) -> np.ndarray:
        """(n_stripes, 4, 3) world corners [m] of the current row's cells on the belt plane (z = 0),
        each cell's corners in the order (x_lo, y_lo), (x_hi, y_lo), (x_hi, y_hi), (x_lo, y_hi)."""
        x_lo, x_hi = self.band(speed, t)
        edges = self.stripe_edges()
        corners = np.zeros((self.n_stripes, 4, 3))
        for j in range(self.n_stripes):
            y_lo, y_hi = edges[j], edges[j + 1]
            corners[j, :, :2] = [[x_lo, y_lo], [x_hi, y_lo], [x_hi, y_hi], [x_lo, y_hi]]
        return corners

    def stripe_of(self, y: np.ndarray) -> np.ndarray:
        """Stripe index of each y [m]; -1 off the belt."""
        y = np.asarray(y, dtype=np.float64)
        index = np.floor((y - self.y_min) / self.stripe_width).astype(int)
        return np.where((index >= 0) & (index < self.n_stripes), index, -1)
