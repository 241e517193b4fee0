"""Perception: camera model, calibration, belt grid, observation codes, HMMs, items."""
