"""sim.sensing: What the cell knows of the belt: perception, classifier, stripe HMMs, tracks."""
