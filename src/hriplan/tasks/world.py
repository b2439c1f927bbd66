"""A task in the world a planning session has perceived, and a task continued from its state.

A task file describes its world as it was written; a session (the plug-in API's) knows the world
as it is: obstacles seen since, people who walked in or moved, what the robot holds now. A task
run on a session plans in both: the task's entities are placed as the file says unless the session
perceives them (a person or object of a task's name is where the session has it: where they
stand, where it stands, or the arm that holds it), and everything else the session perceives
stays: obstacles, people (their role from the session's roles, else bystanders, so the rules
protect them), objects the robot holds (of the ontology's generic class unless the task names
them). The result is a task file, so the runner, the rules and the checks see one world.
"""

from __future__ import annotations

from collections.abc import Mapping

from pydantic import ValidationError

from hriplan import HriplanError
from hriplan.files import validation_message
from hriplan.robots.human import handing_hand
from hriplan.robots.scene import Scene
from hriplan.safety.policy import DEFAULT_ROLE
from hriplan.tasks.grasps import Grasp, grasp_holding
from hriplan.tasks.model import TaskFile, step_name

# The class of a held object the session perceives and the task does not name.
PERCEIVED_KIND = "PhysicalObject"


def in_world(task: TaskFile, world: Scene, roles: Mapping[str, str] | None = None) -> tuple[TaskFile, dict[str, Grasp]]:
    """The task placed in the perceived `world`, and the grasp of each object the robot holds there
    (from its pose in the hand). `roles`: of perceived people the task does not name."""
    roles = roles or {}
    data = task.model_dump(by_alias=True)
    people = {h["name"]: h for h in data["humans"]}
    objects = {o["name"]: o for o in data["objects"]}
    tables = {t["name"] for t in data["scene"]["tables"]}
    for name in {o.name for o in world.obstacles} | {a.name for a in world.attached}:
        if name in people:
            raise HriplanError(f"the session's object {name!r} is a person in task {task.name!r}")
    for spec in world.humans:
        if spec.name in objects or spec.name in tables:
            raise HriplanError(f"the session's person {spec.name!r} is an object in task {task.name!r}")
        seen = spec.model_dump()
        if spec.name in people:
            people[spec.name] |= seen
        else:
            role = roles.get(spec.name, DEFAULT_ROLE)
            people[spec.name] = seen | {"role": role, "hand": handing_hand(spec)}
    obstacles = {o["name"]: o for o in data["scene"]["obstacles"]}
    for seen in world.obstacles:
        standing = seen.model_copy(update={"touched_by": None})
        if seen.name in objects:
            objects[seen.name] |= {"pose": seen.pose.model_dump(), "shape": seen.shape.model_dump()}
            objects[seen.name] |= {"held_by": None, "in_hand_of": None}
        else:
            tables.discard(seen.name)  # a table seen is where it is seen
            obstacles[seen.name] = standing.model_dump()
    grasps = {}
    for held in world.attached:
        shape = held.shape.model_dump()
        placed = objects.setdefault(held.name, {"name": held.name, "kind": PERCEIVED_KIND, "shape": shape})
        placed |= {"shape": shape, "held_by": held.arm, "in_hand_of": None}
        grasps[held.name] = grasp_holding(held.grasp.se3(), held.shape)
    data["humans"], data["objects"] = list(people.values()), list(objects.values())
    data["scene"] = {
        "tables": [t for t in data["scene"]["tables"] if t["name"] in tables],
        "obstacles": list(obstacles.values()),
    }
    try:
        return TaskFile.model_validate(data), grasps
    except ValidationError as exc:
        raise HriplanError(f"task {task.name!r} in the session's world: {validation_message(exc)}") from None


def continued(task: TaskFile, from_step: str, start: Mapping[str, float]) -> TaskFile:
    """The task from its step `from_step` on (the steps keep their names), the robot starting at
    `start` (joint values on top of the task's start posture)."""
    names = [step_name(step, k) for k, step in enumerate(task.steps)]
    if from_step not in names:
        raise HriplanError(f"task {task.name!r} has no step {from_step!r}; steps: {', '.join(names)}")
    first = names.index(from_step)
    steps = [step.model_copy(update={"name": name}) for step, name in zip(task.steps[first:], names[first:])]
    begin = task.start.model_copy(update={"joints": {**task.start.joints, **start}})
    return task.model_copy(update={"steps": steps, "start": begin})
