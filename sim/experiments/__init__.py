"""sim.experiments."""
