"""sim.render: Pictures of the cell: the episode's video, the live viewer, the calibration rig."""
