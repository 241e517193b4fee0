"""Motion planning and decision making: delta kinematics, ruckig trajectories, pick choice."""
