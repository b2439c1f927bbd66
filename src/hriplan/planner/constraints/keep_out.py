"""Keep-out zones: `outside` volume constraints that every robot link must also respect.

The seed framework kept only the end effector out of a person's cylinder; the elbow must not
enter it either. Each such volume becomes an obstacle for the collision checker.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from hriplan.planner.constraints.binding import BoundConstraint
from hriplan.planner.constraints.spec import BoxConstraint, ConeConstraint, CylinderConstraint, SphereConstraint
from hriplan.robots.scene import Box, Cone, Cylinder, Obstacle, Sphere
from hriplan.robots.spatial import Pose

KEEP_OUT_PREFIX = "keep-out:"


def keep_out_obstacles(constraints: list[BoundConstraint]) -> list[Obstacle]:
    """Obstacles for the bound constraints that ask to keep all links out."""
    obstacles = []
    for c in constraints:
        spec = c.spec
        if not getattr(spec, "keep_out_all_links", False):
            continue
        local = pin.SE3.Identity()
        if isinstance(spec, BoxConstraint):
            shape = Box(size=spec.size)
        elif isinstance(spec, SphereConstraint):
            shape = Sphere(radius=spec.radius)
        elif isinstance(spec, CylinderConstraint):
            shape = Cylinder(radius=spec.radius, height=spec.height)
            local = pin.SE3(np.eye(3), np.array([0.0, 0.0, spec.height / 2.0]))
        elif isinstance(spec, ConeConstraint):
            shape = Cone(radius=spec.radius, height=spec.height)
            local = pin.SE3(pin.rpy.rpyToMatrix(math.pi, 0.0, 0.0), np.array([0.0, 0.0, spec.height / 2.0]))
        else:
            continue
        obstacles.append(Obstacle(name=f"{KEEP_OUT_PREFIX}{spec.id}", shape=shape, pose=Pose.from_se3(c.frame * local)))
    return obstacles
