"""sortsim: physics digital twin of a robotic recycling sorting cell (MuJoCo side)."""
