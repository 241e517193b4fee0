"""The episode's own hooks around each physics step and its observation event, registered by
`Episode._register` (`sim.episode.loop`) as a user's would be (`Episode.add_hook`,
`Episode.every`): the robots' set-points before a step; the riders' belt time, the actuator
log and the cups after it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from sim.episode.loop import Episode


def set_points(episode: Episode) -> None:
    """Before a step: the busy robots' set-points of the coming control period."""
    for station in episode.busy:
        station.robot.before_step()


def carry_riders(episode: Episode) -> None:
    """After a step: the belt's time the riders are owed (`sim.cell.riding`)."""
    episode.riding.carry(episode.last_step_s)


def log_actuators(episode: Episode) -> None:
    """After a step: the actuators' power over it, for the energy meters."""
    episode.actuator_log.record(episode.last_step_s)


def cups(episode: Episode) -> None:
    """After a step: the busy robots' cups (seal, hold, release)."""
    for station in episode.busy:
        station.robot.after_step()


def observe(episode: Episode) -> None:
    """Every observation period: the perception's detections (`Episode.observe`)."""
    episode.observe()


BEFORE_STEP = (set_points,)
"""The episode's own before-step hooks, in order."""
AFTER_STEP = (carry_riders, log_actuators, cups)
"""The episode's own after-step hooks, in order."""
