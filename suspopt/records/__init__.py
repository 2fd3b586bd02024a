"""Typed records of what suspopt computes: trajectories, solves, verifications, studies."""
