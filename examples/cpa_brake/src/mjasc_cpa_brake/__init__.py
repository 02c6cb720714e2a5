"""Example mjasc plugin: the speed-only collision-avoidance method ``cpa_brake``."""
