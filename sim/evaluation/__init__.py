"""sim.evaluation: measuring and training the parts (perception scores, data sets, cycle fits,
the learned policy)."""
