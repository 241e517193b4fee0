"""perception.items."""
