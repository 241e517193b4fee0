"""The parts of `sortsim report` (`sim.experiments.report`): its statistics, how it groups the
episodes, and the tables a plant reads (recovery per material, figures per hour, what one more
robot earns)."""
