"""sim.monitors: what watches the physics while an episode runs (MuJoCo's warnings,
items thrown off the belt, the motors' energy)."""
