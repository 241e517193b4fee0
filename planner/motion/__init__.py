"""planner.motion."""
