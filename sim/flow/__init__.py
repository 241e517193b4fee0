"""sim.flow."""
