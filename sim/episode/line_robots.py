"""The robots of an episode config live in `sim.config.robots`; this name follows it until the
imports do."""

from sim.config.robots import *  # noqa: F403
