"""Constrained motion planning: constraints, OMPL, validation, trajectories."""
