"""Constraints: their specification, binding to a robot, geometry, margins with Jacobians, projection."""
