"""perception.camera."""
