"""Uncertainty and tolerance studies by Monte Carlo (see docs/studies.md)."""
