"""Cooperation: the lossy, delayed comms link and cooperative path following."""
