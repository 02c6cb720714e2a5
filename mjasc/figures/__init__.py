"""Thesis-style figures made from the code."""
