"""Perception: range sensing, detection, static map, IMM tracking."""
