"""planner.decision."""
