"""Task file to trajectories, one stage at a time (each callable on its own):

task file -> per step: situation (facts) -> knowledge base + rules -> derived constraints with
provenance -> planning scene and goal -> plan -> validated, timed trajectory.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin
from pydantic import BaseModel, Field

from hriplan import HriplanError
from hriplan.ontology.assertions import arm_individual
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.situation import Situation, SituationHuman, SituationObject, SituationTask
from hriplan.planner.motion import JointGoal, ToolGoal
from hriplan.planner.options import PlanOptions
from hriplan.planner.session import PlanningSession
from hriplan.planner.trajectory import ResolvedConstraint, TrajectoryFile
from hriplan.robots.ik import solve_two_arms
from hriplan.robots.model import arms_of
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose
from hriplan.robots.postures import posture
from hriplan.rules.infer import Derivation, derive
from hriplan.rules.instantiate import Context

from .goals import ResolvedGoal, after_step, resolve_goal, task_kind
from .model import Step, TaskFile
from .world import TaskState, object_in_tool

Progress = Callable[[str], None]


class StepOutcome(BaseModel):
    name: str
    kind: str
    arms: list[str]
    status: str
    message: str = ""
    derivation: Derivation = Field(default_factory=Derivation)
    scene: Scene = Field(default_factory=Scene)  # what the step is planned (and validated) against
    trajectory: TrajectoryFile | None = None


class TaskOutcome(BaseModel):
    task: str
    steps: list[StepOutcome]

    @property
    def solved(self) -> bool:
        return all(s.status == "solved" for s in self.steps)


def step_name(step: Step, index: int) -> str:
    return step.name or f"step{index + 1}"


def step_arms(task: TaskFile, step: Step, state: TaskState) -> list[str]:
    """The arms a step moves: given, else the one holding its object, else the first arm."""
    if step.goals:
        return list(step.arms)
    if step.arm:
        return [step.arm]
    for field in ("hand_over", "place", "insert"):
        obj = getattr(step.goal, field, None)
        if obj in state.held_by_arm:
            return [state.held_by_arm[obj]]
    return ["right"] if task.robot == "madar" else ["arm"]


def situation_for(task: TaskFile, step: Step, index: int, state: TaskState) -> Situation:
    """The facts of one step: the task kind, who is involved, what is carried, where things are."""
    arms = step_arms(task, step, state)
    goals = step.goals or [step.goal]
    human = next((getattr(g, a) for g in goals for a in ("to", "from_") if getattr(g, a, None)), None)
    targets = {g.insert: g.into for g in goals if getattr(g, "into", None)}
    target = next(iter(targets.values())) if len(set(targets.values())) == 1 else None
    carries = {obj: arm for obj, arm in state.held_by_arm.items() if arm in arms}
    # An object this step grasps or takes is moved by it too: the hand arrives as it will hold it.
    for goal, arm in zip(goals, arms):
        taken = getattr(goal, "take", None) or getattr(goal, "grasp", None)
        if taken is not None:
            carries[taken] = arm
    objects = [
        SituationObject(name=o.name, kind=o.kind, fill_level=o.fill_level, open=o.open, sharp=o.sharp, fragile=o.fragile,
                        hot=o.hot, pose=state.pose(o.name))  # fmt: skip
        for o in task.objects
    ]
    humans = [SituationHuman(**h.model_dump()) for h in task.humans]
    kind = step.kind or task_kind(goals[0])
    return Situation(robot=task.robot, objects=objects, humans=humans,
                     task=SituationTask(name=step_name(step, index), kind=kind, arms=arms, carries=carries, human=human,
                                           target=target, targets=targets))  # fmt: skip


def object_axes(kb: KnowledgeBase, arms: list[str]) -> dict[str, str]:
    """Per arm, the tool axis along a held object's axis (from the ontology)."""
    ctx = Context(kb.situation, kb.facts)
    return {arm: ctx.arm(arm_individual(kb.situation.robot, arm)).object_axis for arm in arms}


class TaskRunner:
    """Runs a task's steps in order on one planning session (robot and collision set-up built once)."""

    def __init__(self, task: TaskFile, base_dir: Path = Path("."), progress: Progress | None = None,
                 session: PlanningSession | None = None) -> None:  # fmt: skip
        self.task = task
        self.rule_files = [str((base_dir / f).resolve()) for f in task.rule_files]
        self.progress = progress or (lambda message: None)
        if session is not None and (session.robot.name, session.robot.hand_postures) != (task.robot, _hands(task)):
            raise HriplanError(f"the session's robot ({session.robot.name}, hands {session.robot.hand_postures}) is not the task's")
        self.session = session
        self.knowledge_bases: dict[str, KnowledgeBase] = {}  # per step, from the last run

    def derive_step(self, step: Step, index: int, state: TaskState) -> tuple[KnowledgeBase, Derivation]:
        situation = situation_for(self.task, step, index, state)
        self.progress(f"{situation.task.name}: reasoning about the situation")
        kb = KnowledgeBase(situation, rule_files=self.rule_files)
        return kb, derive(kb)

    def run(self, plan: bool = True) -> TaskOutcome:
        """Derive (and plan, unless `plan` is False) every step."""
        task, state = self.task, TaskState.initial(self.task)
        start = posture(task.robot, task.start.posture) | task.start.joints
        outcomes = []
        for index, step in enumerate(task.steps):
            kb, derivation = self.derive_step(step, index, state)
            self.knowledge_bases[kb.situation.task.name] = kb
            arms = kb.situation.task.arms
            axes = object_axes(kb, list(arms_of(task.robot)))
            goals = step.goals or [step.goal]
            held = self._held_axes(start, state, axes) if plan else {}
            resolved = [resolve_goal(g, arm, state, axes[arm], held.get(arm)) for g, arm in zip(goals, arms)]
            grasped = {r.moved_object for r in resolved if r.moved_object and r.moved_object not in state.held_by_arm}
            outcome = StepOutcome(name=kb.situation.task.name, kind=kb.situation.task.kind, arms=arms, status="derived",
                                  derivation=derivation, scene=state.scene(axes, leave_out=grasped))  # fmt: skip
            if plan:
                outcome, start = self._plan_step(derivation, resolved, start, outcome)
            outcomes.append(outcome)
            if outcome.status not in ("solved", "derived"):
                break
            for g, arm, r in zip(goals, arms, resolved):
                after_step(g, r, arm, state)
        return TaskOutcome(task=task.name, steps=outcomes)

    def _session(self) -> PlanningSession:
        if self.session is None:
            self.progress("loading the robot and its collision model")
            self.session = PlanningSession(self.task.robot, hands=self.task.hands or None)
        return self.session

    def _plan_step(self, derivation: Derivation, resolved: list[ResolvedGoal], start: dict[str, float],
                   outcome: StepOutcome) -> tuple[StepOutcome, dict[str, float]]:  # fmt: skip
        session, robot = self._session(), self._session().robot
        arms = outcome.arms
        session.set_scene(outcome.scene)
        session.set_constraints(derivation.constraint_set())
        group = robot.arm_group(arms[0]) if len(arms) == 1 else robot.default_group
        options = PlanOptions(planner=self.task.planning.planner, space=self.task.planning.space, time_limit=self.task.planning.time_limit,
                              seed=self.task.planning.seed, velocity_scale=derivation.velocity_scale)  # fmt: skip
        goal = resolved[0].goal if len(resolved) == 1 else self._joint_goal(resolved, start)
        self.progress(f"{outcome.name}: planning ({len(derivation.constraints)} constraints)")
        result = session.plan(start, goal, options, group)
        if not result.solved:
            return outcome.model_copy(update={"status": result.motion.status, "message": result.message}), start
        trajectory = _with_reasons(result.trajectory, derivation).model_copy(update={"task": self.task.name, "step": outcome.name})
        end = dict(start) | dict(zip(trajectory.joint_names, trajectory.points[-1].positions))
        return outcome.model_copy(update={"status": "solved", "trajectory": trajectory}), end

    def _held_axes(self, start: dict[str, float], state: TaskState, axes: dict[str, str]) -> dict[str, np.ndarray]:
        """Per arm holding something: the world direction of the held object's axis at `start`."""
        robot = self._session().robot
        q = robot.configuration(start)
        held = {}
        for arm in set(state.held_by_arm.values()):
            tool = pin.SE3(robot.frame_pose(robot.tool_frame(arm), q))
            held[arm] = (tool * object_in_tool(axes[arm])).rotation[:, 2].copy()
        return held

    def _joint_goal(self, resolved: list[ResolvedGoal], start: dict[str, float]) -> JointGoal:
        """Two arms' tool goals as one joint goal: IK for both, clear of each other and the scene."""
        session = self._session()
        robot, checker = session.robot, session.checker
        targets = []
        for r in resolved:
            if not isinstance(r.goal, ToolGoal):
                raise HriplanError("a step with several goals needs a tool or object goal for each arm")
            targets.append((r.goal.arm, r.goal.pose.matrix(), r.goal.free_axes))
        q = solve_two_arms(robot, targets[0], targets[1], robot.configuration(start), lambda full: not checker.in_collision(full))
        if q is None:
            raise HriplanError("no collision-free configuration puts both arms at their goals")
        return JointGoal(values=dict(zip(robot.joint_names, q.tolist())))


def _hands(task: TaskFile) -> dict[str, str]:
    """The task's hand postures as a loaded robot reports them (unnamed hands open)."""
    return {side: task.hands.get(side, "open") for side in arms_of(task.robot)} if task.robot == "madar" else {}


def _with_reasons(trajectory: TrajectoryFile, derivation: Derivation) -> TrajectoryFile:
    by_id = {c.spec.id: c for c in derivation.constraints}
    constraints = [c.model_copy(update={"reason": by_id[c.spec.id].reason}) if c.spec.id in by_id else c for c in trajectory.constraints]
    return trajectory.model_copy(update={"constraints": constraints})


def against_task(trajectory: TrajectoryFile, runner: TaskRunner) -> TrajectoryFile:
    """The trajectory with its step's constraints (and reasons) and scene as the task derives
    them now, so it can be re-checked or shown against the task rather than its own record."""
    outcome = runner.run(plan=False)
    step = next((s for s in outcome.steps if s.name == trajectory.step), None)
    if step is None:
        raise HriplanError(f"the trajectory's step {trajectory.step!r} is not a step of task {runner.task.name!r}")
    resolved = [ResolvedConstraint(spec=c.spec, frame_in_world=Pose(), reason=c.reason) for c in step.derivation.constraints]
    return trajectory.model_copy(update={"constraints": resolved, "scene": step.scene})
