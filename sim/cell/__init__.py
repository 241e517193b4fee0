"""sim.cell."""
