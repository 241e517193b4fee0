"""sim.episode."""
