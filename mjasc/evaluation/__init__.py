"""Evaluation: how well a run went, measured against the simulator's truth (never seen by the
vessels): rule-of-the-road roles and compliance per encounter, closest points of approach, and
tracking accuracy (GOSPA, identity switches, time to confirm)."""
