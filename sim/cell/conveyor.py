"""The conveyor belt: a static box whose top surface moves (MuJoCo `geom/surfacevel`).

The belt never moves as a body: MuJoCo gives the contacts of geom `belt` a tangential surface
velocity, so items resting on it are carried by friction alone (no teleporting, no velocity
writes). The speed is changed at run time through `model.geom_surfacevel[belt]` (six components
in MuJoCo 4: linear x, y, z and angular x, y, z; only the linear x is used).

The belt's encoder (`BeltEncoder`) reads how far the surface has run: what a line-scan camera
triggers its rows on, so its rows stay one row of belt apart when a fault stops or slows the belt.

The thesis's conveyor runs at 135-277 mm/s (section 2.1.1). Its experiments use speed factors
x1, x1.2 and x1.5; we set x1 = 0.185 m/s so that x1.5 = 0.2775 m/s is the conveyor's top
speed, which is rated to the whole millimetre per second (the range check therefore allows half
a millimetre per second of rounding on each side).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from planner.motion.belt_speeds import (
    SPEED_FACTORS,
    SPEED_RANGE_MPS,
    SPEED_TOLERANCE_MPS,
    SPEED_X1_MPS,
)
from sim.errors import InvalidInput

BELT_GEOM = "belt"
RAIL_GEOMS = ("rail_left", "rail_right")
SPEED_MIN, SPEED_MAX = SPEED_RANGE_MPS
SPEED_X1 = SPEED_X1_MPS
_RATING_RESOLUTION = SPEED_TOLERANCE_MPS


def rail_top_z(model: mujoco.MjModel) -> float:
    """Top of the belt's side rails [m], the highest obstacle between the belt and the bins,
    read from the compiled model (static boxes `rail_left`, `rail_right` on the world body)."""
    tops = []
    for name in RAIL_GEOMS:
        geom = model.geom(name)
        tops.append(float(geom.pos[2] + geom.size[2]))
    return max(tops)


def speed_for_factor(factor: float) -> float:
    """Belt speed [m/s] of a thesis speed factor (1, 1.2 or 1.5).

    Raises:
        InvalidInput: `factor` is not one of `SPEED_FACTORS`.
    """
    for allowed in SPEED_FACTORS:
        if np.isclose(factor, allowed, rtol=0.0, atol=1e-9):
            return SPEED_X1 * allowed
    raise InvalidInput("speed_factor", "one of 1, 1.2, 1.5", factor)


def check_speed(speed: float) -> float:
    """Validates a belt speed [m/s] against the conveyor's range and returns it as a float.

    Raises:
        InvalidInput: `speed` is not a finite number in [0.135, 0.277] m/s.
    """
    ok = isinstance(speed, int | float | np.floating) and np.isfinite(speed)
    if not ok or not (
        SPEED_MIN - _RATING_RESOLUTION <= speed <= SPEED_MAX + _RATING_RESOLUTION + 1e-12
    ):
        raise InvalidInput("belt_speed", f"{SPEED_MIN} to {SPEED_MAX} m/s", speed)
    return float(speed)


@dataclass(frozen=True)
class BeltGeometry:
    """Where the belt's top surface is, read from geom `belt` [m].

    Attributes:
        x_infeed: Upstream end of the top surface.
        x_discharge: Downstream end.
        y_half: Half the belt's width (the surface spans -y_half..y_half about `y_centre`).
        y_centre: Centre line.
        top_z: Height of the top surface.
    """

    x_infeed: float
    x_discharge: float
    y_half: float
    y_centre: float
    top_z: float

    def on_belt(self, xy: np.ndarray) -> np.ndarray:
        """Whether points (..., 2) [m] lie over the belt's top surface (boolean array)."""
        xy = np.asarray(xy, dtype=float)
        return (
            (xy[..., 0] >= self.x_infeed)
            & (xy[..., 0] <= self.x_discharge)
            & (np.abs(xy[..., 1] - self.y_centre) <= self.y_half)
        )


class BeltEncoder:
    """How far the belt's surface has run since the episode's start [m], as an encoder on its
    drive reads it: at the set speed from t = 0, then at each speed a fault sets from its time.

    The belt's clock (`clock`) is the time the travel takes at the set speed [s]: the sim time
    itself until a fault changes the speed (so a run without faults reads exactly its time).

    Args:
        set_speed: The belt's set speed [m/s], > 0.
    """

    def __init__(self, set_speed: float):
        self.reset(set_speed)

    def reset(self, set_speed: float) -> None:
        """At t = 0, at `set_speed` [m/s], nothing run yet."""
        self.set_speed = self.speed = float(set_speed)
        self._t0 = self._x0 = 0.0
        self.changed = False
        """Whether a fault has changed the speed since t = 0."""

    def run_at(self, t: float, speed: float) -> None:
        """The belt runs at `speed` [m/s] from sim time `t` [s] on."""
        self._x0, self._t0 = self.travel(t), float(t)
        self.speed, self.changed = float(speed), True

    def travel(self, t: float) -> float:
        """How far the belt has run at sim time `t` [s] (not before the last change) [m]."""
        if not self.changed:
            return self.speed * t
        return self._x0 + self.speed * (t - self._t0)

    def clock(self, t: float) -> float:
        """The belt's clock at sim time `t` [s]: its travel over its set speed [s]."""
        return t if not self.changed else self.travel(t) / self.set_speed

    def time_at(self, clock: float) -> float | None:
        """When the belt's clock reads `clock` [s] at the speed it runs now: a sim time [s]
        (None while the belt stands)."""
        if not self.changed:
            return clock
        if self.speed <= 0.0:
            return None
        return self._t0 + (clock * self.set_speed - self._x0) / self.speed


class Belt:
    """Speed control and geometry of the belt geom of a compiled model.

    Args:
        model: Model holding an axis-aligned box geom named `belt` on the world body.

    Raises:
        InvalidInput: no such geom, or it is not an axis-aligned box.
    """

    def __init__(self, model: mujoco.MjModel, geom_name: str = BELT_GEOM):
        geom_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, geom_name)
        if geom_id < 0:
            raise InvalidInput("belt", f"a box geom named {geom_name!r} in the model", None)
        if model.geom_type[geom_id] != mujoco.mjtGeom.mjGEOM_BOX or model.geom_bodyid[geom_id]:
            raise InvalidInput("belt", "a box geom on the world body", geom_name)
        if not np.allclose(model.geom_quat[geom_id], (1.0, 0.0, 0.0, 0.0)):
            raise InvalidInput("belt", "an axis-aligned box", model.geom_quat[geom_id].tolist())
        self._model = model
        self.geom_id = geom_id
        self.encoder = BeltEncoder(max(self.speed, SPEED_MIN))
        """The belt's encoder, reset at each `set_speed` (an episode's start)."""
        pos, size = model.geom_pos[geom_id], model.geom_size[geom_id]
        self.geometry = BeltGeometry(
            x_infeed=float(pos[0] - size[0]),
            x_discharge=float(pos[0] + size[0]),
            y_half=float(size[1]),
            y_centre=float(pos[1]),
            top_z=float(pos[2] + size[2]),
        )

    @property
    def speed(self) -> float:
        """Current belt speed along +x [m/s]."""
        return float(self._model.geom_surfacevel[self.geom_id, 0])

    def set_speed(self, speed: float) -> None:
        """Sets the belt speed [m/s]; takes effect at the next step; the encoder starts again
        from 0 at this speed (the clock at 0: an episode's start).

        Raises:
            InvalidInput: outside the conveyor's 0.135-0.277 m/s.
        """
        speed = check_speed(speed)
        surfacevel = self._model.geom_surfacevel[self.geom_id]
        surfacevel[:] = 0.0
        surfacevel[0] = speed
        self.encoder.reset(speed)

    def run_at(self, speed: float, t: float) -> None:
        """Runs the belt at `speed` [m/s] from sim time `t` [s] on whatever the conveyor's
        rating: a fault's stop (0) or slowdown (`sim.config.faults`), at most twice the rated
        top speed; the encoder counts on at it.

        Raises:
            InvalidInput: outside 0 to twice the rated top speed.
        """
        ok = isinstance(speed, int | float | np.floating) and 0.0 <= speed <= 2.0 * SPEED_MAX
        if not ok:
            raise InvalidInput("belt_speed", f"0 to {2.0 * SPEED_MAX:g} m/s (a fault's)", speed)
        surfacevel = self._model.geom_surfacevel[self.geom_id]
        surfacevel[:] = 0.0
        surfacevel[0] = float(speed)
        self.encoder.run_at(t, speed)

    def set_factor(self, factor: float) -> float:
        """Sets the speed of a thesis speed factor (1, 1.2, 1.5) and returns it [m/s]."""
        speed = speed_for_factor(factor)
        self.set_speed(speed)
        return speed
