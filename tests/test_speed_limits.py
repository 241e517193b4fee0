"""Belt speeds just inside and just outside every limit the code enforces.

The conveyor runs from 0.135 to 0.277 m/s, rated to the whole mm/s, and x1.5 = 0.2775 m/s is its
top speed. The limits and their tolerances, as the code states them:

- `sim.cell.conveyor.check_speed` (and so `Belt.set_speed`): half a mm/s of rating resolution on
  each side, 0.1345 <= v <= 0.2775 m/s (plus 1e-12 of rounding).
- `EpisodeConfig` and `FlowConfig` (speed factors, x1 = 0.185 m/s): 0.135 m/s less 1e-9 up to
  0.277 m/s plus 0.6 mm/s, i.e. 0.2776 m/s.

Each limit is probed 1 um/s (1e-6 m/s) inside and outside, and the floating-point slacks
(1e-12 m/s on the belt's top, 1e-9 m/s on the configs' bottom) at twice and half their size: a
tolerance ten times too wide, or one dropped, moves the verdict of one of the probes. A speed
factor the configuration accepts must also be one the belt accepts, or the episode is refused
only when it starts.
"""

from __future__ import annotations

import pytest

from planner.motion.belt_speeds import SPEED_RANGE_MPS, SPEED_X1_MPS
from sim import config
from sim.cell.conveyor import Belt, check_speed
from sim.errors import InvalidInput
from sim.flow.config import FlowConfig
from tests.utils import scene_at_home

EPS = 1e-6  # [m/s] how far inside / outside a limit each probe is
BELT_LOW, BELT_HIGH = 0.1345, 0.2775  # check_speed's limits with their half mm/s
CONFIG_LOW, CONFIG_HIGH = (
    0.135,
    0.2775,
)  # EpisodeConfig's and FlowConfig's: the belt's own upper limit


def factor(speed: float) -> float:
    """Speed factor of a belt speed [m/s] (x1 = 0.185 m/s)."""
    return speed / SPEED_X1_MPS


def test_the_stated_range_and_x1():
    assert SPEED_RANGE_MPS == (0.135, 0.277)
    assert SPEED_X1_MPS == 0.185
    assert SPEED_X1_MPS * 1.5 == pytest.approx(0.2775, abs=1e-15)


@pytest.mark.parametrize(
    "speed", [BELT_LOW + EPS, 0.135, 0.185, 0.2775, 0.277, BELT_HIGH - EPS, SPEED_X1_MPS * 1.5]
)
def test_check_speed_accepts_just_inside(speed):
    assert check_speed(speed) == speed


@pytest.mark.parametrize(
    "speed",
    [BELT_LOW - EPS, BELT_HIGH + EPS, 0.134, 0.278, 0.0, -0.185, float("nan"), float("inf")],
)
def test_check_speed_refuses_just_outside(speed):
    with pytest.raises(InvalidInput, match=r"belt_speed: allowed 0\.135 to 0\.277 m/s"):
        check_speed(speed)


def test_belt_takes_the_limits_and_keeps_its_speed_on_a_refusal():
    model, _ = scene_at_home()
    belt = Belt(model)
    belt.set_speed(BELT_HIGH)
    assert belt.speed == BELT_HIGH
    belt.set_speed(BELT_LOW)
    assert belt.speed == BELT_LOW
    for bad in (BELT_HIGH + EPS, BELT_LOW - EPS):
        with pytest.raises(InvalidInput, match="belt_speed"):
            belt.set_speed(bad)
        assert belt.speed == BELT_LOW
    assert belt.set_factor(1.5) == pytest.approx(0.2775, abs=1e-15)
    assert belt.speed == pytest.approx(0.2775, abs=1e-15)


@pytest.mark.parametrize("speed", [CONFIG_LOW, CONFIG_LOW + EPS, 0.277, 0.2775, CONFIG_HIGH - EPS])
def test_episode_config_accepts_factors_just_inside(speed):
    c = config.load(None, speed_factor=factor(speed))
    assert c.belt_speed_mps == pytest.approx(speed, abs=1e-12)
    for f in (1.0, 1.2, 1.5):
        assert config.load(None, speed_factor=f).speed_factor == f


@pytest.mark.parametrize("speed", [CONFIG_LOW - EPS, CONFIG_HIGH + EPS, 0.13, 0.28])
def test_episode_config_refuses_factors_just_outside(speed):
    with pytest.raises(InvalidInput, match="speed_factor"):
        config.load(None, speed_factor=factor(speed))


@pytest.mark.parametrize("speed", [CONFIG_LOW, CONFIG_LOW + EPS, 0.2775, CONFIG_HIGH - EPS])
def test_flow_config_accepts_factors_just_inside(speed):
    flow = FlowConfig(n_items=1, duration_s=10.0, speed_factor=factor(speed))
    assert flow.belt_speed_mps == pytest.approx(speed, abs=1e-12)


@pytest.mark.parametrize("speed", [CONFIG_LOW - EPS, CONFIG_HIGH + EPS])
def test_flow_config_refuses_factors_just_outside(speed):
    with pytest.raises(InvalidInput, match="speed_factor"):
        FlowConfig(n_items=1, duration_s=10.0, speed_factor=factor(speed))


def test_the_rounding_slacks_are_as_tight_as_stated():
    assert check_speed(BELT_HIGH + 0.5e-12) == BELT_HIGH + 0.5e-12
    with pytest.raises(InvalidInput, match="belt_speed"):
        check_speed(BELT_HIGH + 2e-12)
    assert config.load(None, speed_factor=factor(CONFIG_LOW - 0.5e-9)).speed_factor > 0.0
    FlowConfig(n_items=1, duration_s=10.0, speed_factor=factor(CONFIG_LOW - 0.5e-9))
    with pytest.raises(InvalidInput, match="speed_factor"):
        config.load(None, speed_factor=factor(CONFIG_LOW - 2e-9))
    with pytest.raises(InvalidInput, match="speed_factor"):
        FlowConfig(n_items=1, duration_s=10.0, speed_factor=factor(CONFIG_LOW - 2e-9))


@pytest.mark.parametrize("speed", [CONFIG_LOW, 0.2775])
def test_the_belt_takes_every_speed_the_config_takes_at_the_thesis_limits(speed):
    c = config.load(None, speed_factor=factor(speed))
    assert check_speed(c.belt_speed_mps) == pytest.approx(speed, abs=1e-12)


def test_the_belt_takes_every_speed_the_config_takes_above_x1_5():
    c = config.load(None, speed_factor=factor(CONFIG_HIGH - EPS))
    FlowConfig(n_items=1, duration_s=10.0, speed_factor=c.speed_factor)
    check_speed(c.belt_speed_mps)
