"""Collision avoidance: prediction, potential-field re-planning, velocity correction, right of way."""
