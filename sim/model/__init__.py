"""sim.model: Building the cell's MuJoCo model: scene edits, bins, the line, the item pool's XML."""
