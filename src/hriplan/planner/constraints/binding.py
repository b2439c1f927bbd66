"""From constraint specifications to constraints bound to a robot and a scene.

Checks what the seed framework did not: joints form a contiguous chain that the target link
hangs from, constraint groups with overlapping but different joint sets are an error naming both
constraints, and every frame names something that exists.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from hriplan import HriplanError
from hriplan.planner.constraints.spec import ConstraintSpec, FrameRef, OrientationConstraint
from hriplan.recent import MadeFor
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.model import Robot

AXES = {"x": 0, "y": 1, "z": 2}
# Per robot, per (joints, target link): the link's frame id, the chain checked. Every plan binds
# its constraints twice (planning, timing), and checking a chain asks pinocchio a dozen times
# (~8 us a constraint); a robot's model never changes once loaded.
_CHAINS: MadeFor[int] = MadeFor(64)


@dataclass
class BoundConstraint:
    """A constraint with its world frame, its link's frame id and (orientation) its target."""

    spec: ConstraintSpec
    frame: pin.SE3  # world pose of the constraint frame
    link: int  # pinocchio frame id of the target link
    target: np.ndarray | None = None  # orientation target in the constraint frame
    p_goal: np.ndarray | None = None  # world position of the link at the goal (dynamic tolerance)

    @property
    def id(self) -> str:
        return self.spec.id

    @property
    def is_orientation(self) -> bool:
        return isinstance(self.spec, OrientationConstraint)

    @property
    def free(self) -> list[int]:
        return [AXES[a] for a in self.spec.free_axes] if self.is_orientation else []


def resolve_frame(ref: FrameRef, robot: Robot, checker: CollisionChecker) -> pin.SE3:
    """World pose of a constraint frame: world, robot_base, an obstacle, or PERSON/FRAME."""
    offset = ref.offset.se3()
    entity = ref.entity
    if entity == "world":
        return offset
    if entity == "robot_base":
        base = robot.model.frames[robot.frame_id(_base_link(robot))]
        return base.placement * offset
    if "/" in entity:
        person, frame = entity.split("/", 1)
        if person not in checker.humans:
            raise HriplanError(f"constraint frame {entity!r}: the scene has no person {person!r}")
        return checker.humans[person].frame(frame) * offset
    for obstacle in checker.scene.obstacles:
        if obstacle.name == entity:
            return obstacle.pose.se3() * offset
    known = ["world", "robot_base", *(o.name for o in checker.scene.obstacles), *(f"{h}/head" for h in checker.humans)]
    raise HriplanError(f"constraint frame {entity!r} is not in the scene (known: {', '.join(known)}, ...)")


def _base_link(robot: Robot) -> str:
    return robot.description.base_link


def _check_chain(robot: Robot, spec: ConstraintSpec) -> int:
    """The frame id of `spec`'s target link, its joints checked to be a chain the link hangs from."""
    key = (tuple(spec.joints), spec.target_link)
    link = _CHAINS.get((robot,), key)
    if link is None:
        link = _checked_chain(robot, spec)
        _CHAINS.put((robot,), link, key)
    return link


def _checked_chain(robot: Robot, spec: ConstraintSpec) -> int:
    model = robot.model
    ids = []
    for name in spec.joints:
        if name not in robot.joint_names:
            raise HriplanError(f"constraint {spec.id!r}: robot {robot.name!r} has no planning joint {name!r}")
        ids.append(model.getJointId(name))
    for parent, child in zip(ids, ids[1:]):
        if model.parents[child] != parent:
            raise HriplanError(
                f"constraint {spec.id!r}: joints must be a contiguous chain, but {model.names[child]!r} "
                f"does not follow {model.names[parent]!r}"
            )
    if not model.existFrame(spec.target_link):
        raise HriplanError(f"constraint {spec.id!r}: robot {robot.name!r} has no link {spec.target_link!r}")
    link = model.getFrameId(spec.target_link)
    if model.frames[link].parentJoint != ids[-1]:
        raise HriplanError(
            f"constraint {spec.id!r}: target link {spec.target_link!r} does not move rigidly with the last "
            f"joint {spec.joints[-1]!r}"
        )
    return link


def check_groups(specs: Sequence[ConstraintSpec]) -> list[list[ConstraintSpec]]:
    """Group constraints by identical joint sets; overlapping different sets are an error."""
    groups: dict[frozenset[str], list[ConstraintSpec]] = {}
    for spec in specs:
        groups.setdefault(frozenset(spec.joints), []).append(spec)
    keys = list(groups)
    for i, a in enumerate(keys):
        for b in keys[i + 1 :]:
            shared = a & b
            if shared:
                ca, cb = groups[a][0], groups[b][0]
                raise HriplanError(
                    f"constraints {ca.id!r} and {cb.id!r} share joints {', '.join(sorted(shared))} but not all "
                    "of them: a joint may belong to one constraint group only"
                )
    return list(groups.values())


def bind(specs: Sequence[ConstraintSpec], robot: Robot, checker: CollisionChecker) -> list[BoundConstraint]:
    """Enabled constraints, checked and tied to this robot and scene."""
    active = [s for s in specs if s.enabled]
    check_groups(active)
    bound = []
    for spec in active:
        link = _check_chain(robot, spec)
        frame = resolve_frame(spec.frame, robot, checker)
        target = spec.target.rotation() if isinstance(spec, OrientationConstraint) else None
        bound.append(BoundConstraint(spec, frame, link, target))
    return bound


def set_goal_positions(
    robot: Robot,
    bound: Sequence[BoundConstraint],
    q_goal: np.ndarray,
    known: dict[str, list[float] | None] | None = None,
) -> None:
    """Dynamic tolerance is measured from the target link's position at the goal: record it
    (from `known` where a trajectory file already holds it, else by FK at `q_goal`)."""
    known = known or {}
    pin.framesForwardKinematics(robot.model, robot.data, q_goal)
    for c in bound:
        given = known.get(c.id)
        c.p_goal = np.asarray(given, dtype=float) if given is not None else robot.data.oMf[c.link].translation.copy()
