"""Conventions and the typed values that cross stages: frames, geometry, config tables, estimates."""
