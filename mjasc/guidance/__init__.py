"""Guidance and control: arc-length paths and integral-LOS path following."""
