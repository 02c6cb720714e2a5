"""Runs: scenario files, the multi-rate schedule, the vessel agent, the runner and its outputs."""
