"""Task file to trajectories, one stage at a time (each callable on its own):

task file -> per step: situation (facts) -> knowledge base + rules -> derived constraints with
provenance -> planning scene and goal -> plan -> validated, timed trajectory.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from pydantic import BaseModel, Field

from hriplan import HriplanError
from hriplan.ontology.assertions import arm_individual
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.ruleset import Rule, load_rules
from hriplan.ontology.situation import Situation, SituationHuman, SituationObject, SituationTask
from hriplan.planner.constraints.spec import ConstraintSpec
from hriplan.planner.kinematics import carried_paths, tool_poses
from hriplan.planner.lift import lift_path, retreat_path, supports
from hriplan.planner.motion import JointTarget, MotionResult, Target, ToolTarget, plan_motion
from hriplan.planner.options import PlanOptions
from hriplan.planner.outcome import SUCCEEDED, Status
from hriplan.planner.prepare import preparatory_goal
from hriplan.planner.replay import MotionSetting
from hriplan.planner.trajectory import ConstraintOrigin, ResolvedConstraint, TrajectoryFile
from hriplan.robots.descriptions.description import hand_model
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.model import Robot, arms_of, description_of, load_robot
from hriplan.robots.scene import Scene
from hriplan.rules.infer import Derivation, derive
from hriplan.rules.instantiate import Context
from hriplan.tasks.goals import LIFT, ResolvedGoal, after_step, resolve_goal, task_kind
from hriplan.tasks.grasps import Grasp, allowed_grasps, stated_grasp
from hriplan.tasks.model import (
    Goal,
    GraspGoal,
    HandOverGoal,
    InsertGoal,
    PlaceGoal,
    PostureGoal,
    Step,
    TaskFile,
    step_name,
)
from hriplan.tasks.task_state import TaskState, human_spec

if TYPE_CHECKING:  # the planner (OMPL, TOPP-RA) loads only when a step is planned
    from hriplan.planner.session import PlanningSession, PlanResult

Progress = Callable[[str], None]
# Motions the pipeline adds to a task step, named after it: leaving a keep-out or a person's S_0
# and a turn in place before, a lift after a pick, the hand opening and backing away after a release.
LEAVE, PREPARE, LIFT_OFF, RELEASE = "_leave", "_prepare", "_lift", "_release"
ADDED_MOTIONS = {
    LEAVE: "the leave phase before",
    PREPARE: "the preparatory motion before",
    LIFT_OFF: "the lift after",
    RELEASE: "the retreat after",
}
# Goals at whose end the arm lets its object go.
RELEASING = (PlaceGoal, HandOverGoal, InsertGoal)


class StepOutcome(BaseModel):
    name: str
    kind: str
    arms: list[str]
    status: Status
    message: str = ""
    derivation: Derivation = Field(default_factory=Derivation)
    scene: Scene = Field(default_factory=Scene)  # what the step is planned (and validated) against
    trajectory: TrajectoryFile | None = None


class TaskOutcome(BaseModel):
    task: str
    steps: list[StepOutcome]
    # The world the solved steps leave (objects where they put them, what the robot holds) and,
    # when planned, where the robot ends (every joint): the state a session continues the task from.
    world: Scene = Field(default_factory=Scene)
    end: dict[str, float] | None = None

    @property
    def solved(self) -> bool:
        return all(s.status == Status.SOLVED for s in self.steps)


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
    return [next(iter(description_of(task.robot).arms))]


def closing_on(step: Step, arms: list[str]) -> dict[str, str]:
    """The objects a step's hands close on at its end (grasped or taken) -> the arm closing on
    each: it holds them from then on, not on its way to them."""
    goals = step.goals or [step.goal]
    return {obj: arm for g, arm in zip(goals, arms) if (obj := getattr(g, "take", None) or getattr(g, "grasp", None))}


def situation_for(
    task: TaskFile,
    step: Step,
    index: int,
    state: TaskState,
    paths: dict[str, list[tuple[float, float, float]]] | None = None,
) -> Situation:
    """The facts of one step: the task kind, who is involved, what is carried (what the arms hold
    as the step starts: an object grasped or taken in it is not carried on the way to it), where
    things are (held objects where the hand is) and, once a motion is planned, the carried
    objects' `paths`."""
    paths = paths or {}
    arms = step_arms(task, step, state)
    goals = step.goals or [step.goal]
    human = next((getattr(g, a) for g in goals for a in ("to", "from_") if getattr(g, a, None)), None)
    targets = {g.insert: g.into for g in goals if getattr(g, "into", None)}
    target = next(iter(targets.values())) if len(set(targets.values())) == 1 else None
    carries = {obj: arm for obj, arm in state.held_by_arm.items() if arm in arms}
    objects = [
        SituationObject(
            name=o.name,
            kind=o.kind,
            fill_level=o.fill_level,
            open=o.open,
            sharp=o.sharp,
            fragile=o.fragile,
            hot=o.hot,
            pose=state.pose(o.name),
            path=paths.get(o.name, []),
            grasp_axis=state.grasps[o.name].axis if o.name in state.grasps else None,
        )
        for o in task.objects
    ]
    humans = [SituationHuman(**h.model_dump()) for h in task.humans]
    kind = step.kind or task_kind(goals[0])
    return Situation(
        robot=task.robot,
        objects=objects,
        humans=humans,
        tool_poses=dict(state.tools),
        task=SituationTask(
            name=step_name(step, index),
            kind=kind,
            arms=arms,
            carries=carries,
            human=human,
            target=target,
            targets=targets,
        ),
    )


def object_axes(kb: KnowledgeBase, arms: list[str]) -> dict[str, str]:
    """Per arm, the tool axis along a held object's axis (from the ontology)."""
    ctx = Context(kb.situation, kb.facts)
    return {arm: ctx.arm(arm_individual(kb.situation.robot, arm)).object_axis for arm in arms}


class TaskRunner:
    """Runs a task's steps in order on one planning session (robot and collision set-up built once)."""

    def __init__(
        self,
        task: TaskFile,
        base_dir: Path = Path("."),
        progress: Progress | None = None,
        session: PlanningSession | None = None,
    ) -> None:
        self.task = task
        self.rule_files = [str((base_dir / f).resolve()) for f in task.rule_files]
        self.progress = progress or (lambda message: None)
        if session is not None and (session.robot.name, session.robot.hand_postures) != (task.robot, _hands(task)):
            raise HriplanError(
                f"the session's robot ({session.robot.name}, hands {session.robot.hand_postures}) is not the task's"
            )
        self.session = session
        self.knowledge_bases: dict[str, KnowledgeBase] = {}  # per step, from the last run
        # Per situation (its JSON): the knowledge base, and what the rules derive from it once asked.
        self._known: dict[str, KnowledgeBase] = {}
        self._derived: dict[str, Derivation] = {}

    def step_knowledge(
        self, step: Step, index: int, state: TaskState, paths: dict[str, list[tuple[float, float, float]]] | None = None
    ) -> tuple[str, KnowledgeBase]:
        """The situation's key and knowledge base: what choosing a grasp reads (the facts), made
        once per situation, without turning them into constraints (`derive_step`)."""
        situation = situation_for(self.task, step, index, state, paths)  # nearness along `paths`: ontology/relations.py
        self.progress(f"{situation.task.name}: reasoning about the situation")
        key = situation.model_dump_json()
        if key not in self._known:
            self._known[key] = KnowledgeBase(situation, rules=self._rules)
        kb = self._known[key]
        self.knowledge_bases[situation.task.name] = kb
        return key, kb

    @functools.cached_property
    def _rules(self) -> tuple[Rule, ...]:
        """The packaged rules and the task's rule files, read when first needed and then once for
        every situation of the runner (each knowledge base read and globbed them: ~0.3 ms)."""
        return load_rules(self.rule_files)

    def derive_step(
        self, step: Step, index: int, state: TaskState, paths: dict[str, list[tuple[float, float, float]]] | None = None
    ) -> tuple[KnowledgeBase, Derivation]:
        """The step's knowledge base and the constraints, velocity scale and ISO/TS 15066 policy
        the rules derive from it (once per situation)."""
        key, kb = self.step_knowledge(step, index, state, paths)
        if key not in self._derived:
            derivation = derive(kb)
            if derivation.separation is not None:  # the task's margin beyond ISO/TS 15066's limits
                margin = {"margin": self.task.planning.safety_margin}
                derivation = derivation.model_copy(
                    update={"separation": derivation.separation.model_copy(update=margin)}
                )
            self._derived[key] = derivation
        return kb, self._derived[key]

    def run(
        self,
        plan: bool = True,
        grasps: Mapping[str, Grasp] | None = None,
        recorded: dict[str, str] | None = None,
    ) -> TaskOutcome:
        """Derive (and plan, unless `plan` is False) every step. Without planning, a step starts
        where the previous one's goal puts the tools. An object the step moves for the first
        time is held by the grasp the task states for it, else tried in each grasp the rules
        allow, most preferred first, until the step plans. `grasps` fixes how objects held from
        the start are held (a session's perceived hold); `recorded` (object -> grasp name, as a
        trajectory records them) fixes the grasp of those objects by name."""
        task, state, robot = self.task, TaskState.initial(self.task), self._robot()
        state.grasps |= {obj: g for obj, g in (grasps or {}).items() if obj in state.held_by_arm}
        start = task_start(task)
        if plan and task.humans:
            session = self._session()
            session.set_scene(Scene(humans=[human_spec(h) for h in task.humans]))
            session.check_people_clear(start)
        state.tools = tool_poses(robot, start)
        outcomes = []
        for index, step in enumerate(task.steps):
            choices = self._grasp_choices(step, index, state, recorded or {})
            for choice in choices if plan else choices[:1]:
                state.grasps |= choice
                planned, end, resolved = self._step(step, index, state, start, plan)
                if planned[-1].status in SUCCEEDED:
                    break
            outcomes += planned
            if planned[-1].status not in SUCCEEDED:
                break
            goals, arms = step.goals or [step.goal], planned[-1].arms
            for g, arm, r in zip(goals, arms, resolved):
                after_step(g, r, arm, state)
            state.grasps = {o: g for o, g in state.grasps.items() if o in state.held_by_arm}
            if plan:
                start, state.tools = end, tool_poses(robot, end)
            else:
                state.tools |= {r.goal.arm: r.goal.pose for r in resolved if isinstance(r.goal, ToolTarget)}
        end = dict(zip(robot.joint_names, robot.configuration(start).tolist())) if plan else None
        return TaskOutcome(task=task.name, steps=outcomes, world=state.scene(), end=end)

    def _grasp_choices(
        self, step: Step, index: int, state: TaskState, recorded: dict[str, str]
    ) -> list[dict[str, Grasp]]:
        """The grasps to try for the objects the step is the first to hold (held from the start,
        grasped or taken now): each allowed grasp of the first such object, in order of
        preference, the others in their preferred one; an object held from the start by a stated
        grasp, or one in `recorded`, only in that one. [{}] when every grasp is already fixed."""
        _, kb = self.step_knowledge(step, index, state)  # the grasp decides the situation derived from
        robot = kb.situation.robot
        usual = object_axes(kb, list(arms_of(self.task.robot)))
        holders = dict(state.held_by_arm) | closing_on(step, kb.situation.task.arms)
        options = {}
        for obj, arm in holders.items():
            if obj in state.grasps:
                continue
            stated, hand = state.object(obj).stated_grasp, arm_individual(robot, arm)
            if stated is not None and obj in state.held_by_arm:
                options[obj] = [stated_grasp(kb.facts, obj, stated, hand)]
            else:
                options[obj] = allowed_grasps(kb.facts, obj, hand, usual[arm])
            if obj in recorded:
                options[obj] = [g for g in options[obj] if g.name == recorded[obj]]
                if not options[obj]:
                    raise HriplanError(
                        f"{obj} is held by {recorded[obj]} in the trajectory, a grasp the task does not allow it "
                        f"at step {step_name(step, index)!r}"
                    )
        if not options:
            return [{}]
        first, *others = options
        rest = {obj: options[obj][0] for obj in others}
        return [{first: g, **rest} for g in options[first]]

    def _step(
        self, step: Step, index: int, state: TaskState, start: dict[str, float], plan: bool
    ) -> tuple[list[StepOutcome], dict[str, float], list[ResolvedGoal]]:
        """Derive, resolve the goals and (if `plan`) plan one step with the grasps in `state`."""
        kb, derivation = self.derive_step(step, index, state)
        arms = kb.situation.task.arms
        goals = step.goals or [step.goal]
        touched = closing_on(step, arms)
        scene = state.scene(touched)
        held = self._held_axes(start, state, derivation, scene) if plan else {}
        resolved = [resolve_goal(g, arm, state, held.get(arm), self._arm_joints(g, arm)) for g, arm in zip(goals, arms)]
        outcome = StepOutcome(
            name=kb.situation.task.name,
            kind=kb.situation.task.kind,
            arms=arms,
            status=Status.DERIVED,
            derivation=derivation,
            scene=scene,
        )
        if not plan:
            return [outcome], start, resolved
        holding = {o: g.name for o, g in state.grasps.items() if o in kb.situation.task.carries | touched}
        planned, end = self._plan_step(step, index, state, resolved, start, outcome)
        if holding and planned[-1].status != Status.SOLVED:
            grasps = ", ".join(state.grasps[o].described(o) for o in holding)
            planned[-1] = planned[-1].model_copy(update={"message": f"{planned[-1].message} (holding {grasps})"})
        # Each trajectory records the grasps it holds its objects by: `validate --task` re-derives with them.
        planned = [
            p.model_copy(update={"trajectory": p.trajectory.model_copy(update={"grasps": holding})})
            if p.trajectory is not None
            else p
            for p in planned
        ]
        return planned, end, resolved

    def _arm_joints(self, goal: Goal, arm: str) -> list[str]:
        """The arm's joints, for a goal that sets them all (a posture); [] for any other goal."""
        if not isinstance(goal, PostureGoal):
            return []
        robot = self._robot()
        return robot.group_joints(robot.arm_group(arm))

    def _robot(self) -> Robot:
        return (
            self.session.robot if self.session is not None else load_robot(self.task.robot, _hands(self.task) or None)
        )

    def _session(self) -> PlanningSession:
        if self.session is None:
            from hriplan.planner.session import worker_session

            self.progress("loading the robot and its collision model")
            self.session = worker_session(self.task.robot, self.task.hands)
        return self.session

    def _plan_step(
        self,
        step: Step,
        index: int,
        state: TaskState,
        resolved: list[ResolvedGoal],
        start: dict[str, float],
        outcome: StepOutcome,
    ) -> tuple[list[StepOutcome], dict[str, float]]:
        """Plan the step, after leaving a keep-out volume or a person's S_0 the start lies in
        (planner/leave.py) and a preparatory motion if its start violates one of its orientation
        or cone constraints (planner/prepare.py), and lift what it picks off its support (planner/lift.py)."""
        session = self._session()
        session.set_scene(outcome.scene)
        left, start = self._leave(outcome, start)
        outcomes = [] if left is None else [left]
        if left is not None and left.status != Status.SOLVED:
            return outcomes, start
        goal = resolved[0].goal if len(resolved) == 1 else self._joint_goal(resolved, start)
        prepared = (
            preparatory_goal(session.robot, session.checker, _pairs(outcome.derivation), start)
            if len(outcome.arms) == 1
            else None
        )
        if prepared is not None:
            turned = set(prepared.violated)
            kept = [c for c in outcome.derivation.constraints if c.spec.id not in turned]
            prep = outcome.model_copy(
                update={
                    "name": f"{outcome.name}{PREPARE}",
                    "kind": "Transport",
                    "derivation": outcome.derivation.model_copy(update={"constraints": kept}),
                }
            )
            self.progress(f"{outcome.name}: the start violates {', '.join(sorted(turned))}; a preparatory motion first")
            prep, start = self._motion(step, index, state, prepared.goal, start, prep, rederive=False)
            prep = prep.model_copy(
                update={
                    "message": f"{prepared.what} before {outcome.name}"
                    if prep.status == Status.SOLVED
                    else f"preparatory motion ({prepared.what}): {prep.message}"
                }
            )
            outcomes.append(prep)
            if prep.status != Status.SOLVED:
                return outcomes, start
        final, end = self._motion(step, index, state, goal, start, outcome)
        outcomes.append(final)
        if final.status == Status.SOLVED and isinstance(step.goal, GraspGoal) and not step.goals:
            lift, end = self._lift(step, index, step.goal, resolved[0], state, end, final)
            outcomes += [lift] if lift is not None else []
        if final.status == Status.SOLVED and isinstance(step.goal, RELEASING) and not step.goals:
            retreat, end = self._release(step.goal, resolved[0], state, end, final)
            outcomes.append(retreat)
        return outcomes, end

    def _leave(self, outcome: StepOutcome, start: dict[str, float]) -> tuple[StepOutcome | None, dict[str, float]]:
        """Where the step's start lies in a keep-out volume or a person's S_0, the motion out of it
        first (planner/leave.py; its own trajectory, timed and validated under the step's
        constraints but the keep-outs it leaves); None where there is nothing to leave."""
        session, derivation = self._session(), outcome.derivation
        session.set_constraints(derivation.constraint_set())
        options = self._options().model_copy(update={"velocity_scale": derivation.velocity_scale})
        result = session.leave(start, options, self._group(outcome.arms), derivation.separation)
        if result is None:
            return None, start
        leaving = outcome.model_copy(update={"name": f"{outcome.name}{LEAVE}", "kind": "Transport"})
        if not result.solved:
            return leaving.model_copy(update={"status": result.status, "message": result.message}), start
        kept = {c.spec.id for c in result.trajectory.constraints}
        derivation = derivation.model_copy(
            update={"constraints": [c for c in derivation.constraints if c.spec.id in kept]}
        )
        self.progress(f"{outcome.name}: the start lies in a keep-out volume or a person's S_0; leaving it first")
        return self._record(leaving.model_copy(update={"derivation": derivation}), result, derivation, start)

    def _group(self, arms: list[str]) -> str:
        """The group a step moves: its one arm's, or the whole robot's."""
        robot = self._session().robot
        return robot.arm_group(arms[0]) if len(arms) == 1 else robot.default_group

    def _lift(
        self,
        step: Step,
        index: int,
        goal: GraspGoal,
        resolved: ResolvedGoal,
        state: TaskState,
        start: dict[str, float],
        grasped: StepOutcome,
    ) -> tuple[StepOutcome | None, dict[str, float]]:
        """After a pick, lift the object straight off what it stands on (planner/lift.py), timed and
        validated under the pick's constraints derived with the object now held (its own rules
        apply from here); None if it stands on nothing."""
        session, robot, (arm,) = self._session(), self._session().robot, grasped.arms
        held = state.copied()
        after_step(goal, resolved, arm, held)
        held.tools = tool_poses(robot, start)
        _, derivation = self.derive_step(step, index, held)
        scene = held.scene()
        session.set_scene(scene)
        q = robot.configuration(start)
        resting = supports(session.checker, q, goal.grasp)
        if not resting:
            return None, start
        lifting = scene.model_copy(
            update={
                "attached": [
                    a.model_copy(update={"resting_on": resting}) if a.name == goal.grasp else a for a in scene.attached
                ]
            }
        )
        session.set_scene(lifting)
        path, why = lift_path(robot, session.checker, arm, q, LIFT)
        outcome = _added_motion(grasped, LIFT_OFF, lifting, derivation)
        group = robot.arm_group(arm)
        if path is not None:
            session.set_scene(scene)
            if session.checker.in_collision(robot.configuration(path[-1], group, base=q)):
                path, why = None, f"{LIFT} m up it still touches {', '.join(resting)}"
        if path is None:
            return outcome.model_copy(
                update={
                    "status": Status.UNREACHABLE_GOAL,
                    "message": f"lifting {goal.grasp} off {', '.join(resting)}: {why}",
                }
            ), start
        session.set_scene(lifting)
        return self._straight(session, outcome, arm, q, path, derivation, start)

    def _release(
        self,
        goal: PlaceGoal | HandOverGoal | InsertGoal,
        resolved: ResolvedGoal,
        state: TaskState,
        start: dict[str, float],
        done: StepOutcome,
    ) -> tuple[StepOutcome, dict[str, float]]:
        """After a place, a handover or an insertion the hand opens (to its hand model's
        `released` posture where that is clear, else it stays as the task closes it) and backs
        straight away (planner/lift.py), touching the released object only at first, and ends
        where the hand, either way, is clear of it: any step can follow. Timed and validated under
        the step's constraints but those on the released object."""
        (arm,) = done.arms
        obj = resolved.moved_object
        after = state.copied()
        after_step(goal, resolved, arm, after)
        closed = self._session()
        hand = description_of(self.task.robot).arms[arm].hand
        sessions = [closed]
        if hand is not None and closed.robot.hand_postures.get(arm) != hand_model(hand).released:
            from hriplan.planner.session import worker_session

            released = closed.robot.hand_postures | {arm: hand_model(hand).released}
            sessions.insert(0, worker_session(self.task.robot, released))
        scene = after.scene({obj: arm})
        q = closed.robot.configuration(start)
        # Every point of the step's trajectory on `q`, in one assignment: its joints are the arm's group's, in order.
        arrival = np.tile(q, (len(done.trajectory.points), 1))
        arrival[:, closed.robot.group_indices(closed.robot.arm_group(arm))] = [
            p.positions for p in done.trajectory.points
        ]
        robots = [s.robot for s in sessions]
        used, path, why = retreat_path(robots, closed.robot, arm, list(arrival), obj, scene, after.scene())
        kept = done.derivation.model_copy(
            update={"constraints": [c for c in done.derivation.constraints if c.anchor != obj]}
        )
        outcome = _added_motion(done, RELEASE, scene, kept)
        if path is None:
            return outcome.model_copy(
                update={"status": Status.UNREACHABLE_GOAL, "message": f"backing away from {obj}: {why}"}
            ), start
        opened = sessions[robots.index(used)]
        opened.set_scene(scene)
        return self._straight(opened, outcome, arm, q, path, kept, start)

    def _straight(
        self,
        session: PlanningSession,
        outcome: StepOutcome,
        arm: str,
        q: np.ndarray,
        path: list[np.ndarray],
        derivation: Derivation,
        start: dict[str, float],
    ) -> tuple[StepOutcome, dict[str, float]]:
        """A straight tool motion of `arm` from `q` through its waypoints `path` (the first is
        `q`'s), timed and validated on `session` (its scene as set) under `derivation`."""
        robot, group = session.robot, session.robot.arm_group(arm)
        session.set_constraints(derivation.constraint_set())
        motion = MotionResult(
            status=Status.SOLVED,
            group=group,
            joint_names=robot.group_joints(group),
            start=dict(zip(robot.joint_names, q.tolist())),
            path=[np.asarray(x).tolist() for x in path],
        )
        return self._timed(outcome, motion, derivation, start, session)

    def _motion(
        self,
        step: Step,
        index: int,
        state: TaskState,
        goal: Target,
        start: dict[str, float],
        outcome: StepOutcome,
        rederive: bool = True,
    ) -> tuple[StepOutcome, dict[str, float]]:
        """Plan the path, re-derive with where it carries each object (nearness along the motion
        decides the velocity rules), then time it under the derived velocity scale."""
        session, robot = self._session(), self._session().robot
        derivation, group = outcome.derivation, self._group(outcome.arms)
        options = self._options()
        self.progress(f"{outcome.name}: planning ({len(derivation.constraints)} constraints)")

        def plan(derivation: Derivation) -> MotionResult:
            session.set_constraints(derivation.constraint_set())
            constraints = list(session.constraints.values())
            return plan_motion(robot, session.checker, constraints, start, goal, options, group, derivation.separation)

        motion = plan(derivation)
        if motion.solved and rederive:
            carries = self.knowledge_bases[outcome.name].situation.task.carries
            _, derivation = self.derive_step(step, index, state, carried_paths(robot, start, motion, carries))
            if derivation.constraint_set() != outcome.derivation.constraint_set():  # user rules may depend on the path
                motion = plan(derivation)
        outcome = outcome.model_copy(update={"derivation": derivation})
        if not motion.solved:
            return outcome.model_copy(update={"status": motion.status, "message": motion.message}), start
        return self._timed(outcome, motion, derivation, start)

    def _timed(
        self,
        outcome: StepOutcome,
        motion: MotionResult,
        derivation: Derivation,
        start: dict[str, float],
        session: PlanningSession | None = None,
    ) -> tuple[StepOutcome, dict[str, float]]:
        """Time a planned motion under the derivation's velocity scale and people, on the session's
        (default: the task's) scene and constraints; the outcome with its trajectory, and where it ends."""
        options = self._options().model_copy(update={"velocity_scale": derivation.velocity_scale})
        result = (session or self._session()).time(motion, options, safety=derivation.separation)
        return self._record(outcome, result, derivation, start)

    def _record(
        self, outcome: StepOutcome, result: PlanResult, derivation: Derivation, start: dict[str, float]
    ) -> tuple[StepOutcome, dict[str, float]]:
        """The outcome of a timed motion: its trajectory with the derivation's reasons and the
        task's names, and where it ends (or the failure, and `start`)."""
        if not result.solved:
            return outcome.model_copy(update={"status": result.status, "message": result.message}), start
        trajectory = result.trajectory.model_copy(
            update={
                "task": self.task.name,
                "step": outcome.name,
                "constraints": _with_origins(result.trajectory.constraints, derivation),
            }
        )
        end = dict(start) | dict(zip(trajectory.joint_names, trajectory.points[-1].positions))
        solved = {"status": Status.SOLVED, "trajectory": trajectory, "message": result.message or outcome.message}
        return outcome.model_copy(update=solved), end

    def _options(self) -> PlanOptions:
        return self.task.planning.options()

    def _held_axes(
        self, start: dict[str, float], state: TaskState, derivation: Derivation, scene: Scene
    ) -> dict[str, np.ndarray]:
        """Per arm holding something: the world direction the held object's axis should keep:
        the target of an orientation constraint on that arm (a blade pointing away), else its
        direction at `start`."""
        session = self._session()
        session.set_scene(scene)
        in_tool = {arm: state.in_tool(obj) for obj, arm in state.held_by_arm.items()}
        return session.held_axes(start, in_tool, _pairs(derivation))

    def _joint_goal(self, resolved: list[ResolvedGoal], start: dict[str, float]) -> JointTarget:
        """Two arms' goals as one joint goal: joint and posture goals side by side, tool goals by
        the session's IK for both, clear of the scene."""
        goals = [r.goal for r in resolved]
        if all(isinstance(g, JointTarget) for g in goals):
            return JointTarget(values={joint: value for g in goals for joint, value in g.values.items()})
        if not all(isinstance(g, ToolTarget) for g in goals):
            raise HriplanError(
                "a step with several goals needs the same kind of goal for each arm: joints or postures, "
                "or tool and object goals"
            )
        return self._session().joint_goal(goals, start)


def _added_motion(done: StepOutcome, suffix: str, scene: Scene, derivation: Derivation) -> StepOutcome:
    """The outcome, still unplanned, of a transport the pipeline adds after the step `done` (a
    lift, a retreat), named after it and planned in `scene` under `derivation`."""
    update = {"name": f"{done.name}{suffix}", "kind": "Transport", "scene": scene, "derivation": derivation}
    return done.model_copy(update=update | {"trajectory": None})


def task_start(task: TaskFile) -> dict[str, float]:
    """The joint values a task starts from: its start posture, then the joints it gives."""
    return posture(task.robot, task.start.posture) | task.start.joints


def _pairs(derivation: Derivation) -> list[tuple[str, ConstraintSpec]]:
    """The derived constraints as (arm, constraint) pairs, as the planning session takes them."""
    return [(c.arm, c.spec) for c in derivation.constraints]


def _hands(task: TaskFile) -> dict[str, str]:
    """The task's hand postures as a loaded robot reports them (an unnamed hand in its model's first)."""
    description = description_of(task.robot)
    return {
        side: task.hands.get(side, hand_model(description.arms[side].hand).postures[0]) for side in description.hands
    }


def _with_origins(constraints: list[ResolvedConstraint], derivation: Derivation) -> list[ResolvedConstraint]:
    """Each constraint with why the rules made it (its kind, anchor, rules, facts and reason)."""
    by_id = {c.spec.id: c for c in derivation.constraints}
    origin = set(ConstraintOrigin.model_fields)
    return [
        c.model_copy(update=by_id[c.spec.id].model_dump(include=origin)) if c.spec.id in by_id else c
        for c in constraints
    ]


def against_task(trajectory: TrajectoryFile, runner: TaskRunner) -> TrajectoryFile:
    """The trajectory with its step's constraints (their frames placed in the step's scene, and
    why the rules made them) and scene as the task derives them now, so it can be re-checked or
    shown against the task rather than its own record."""
    outcome = runner.run(plan=False, recorded=trajectory.grasps)
    step = next((s for s in outcome.steps if s.name == trajectory.step), None)
    if step is None:
        added = next(
            ((suffix, what) for suffix, what in ADDED_MOTIONS.items() if (trajectory.step or "").endswith(suffix)), None
        )
        if added is not None:
            raise HriplanError(
                f"step {trajectory.step!r} is {added[1]} task step {trajectory.step[: -len(added[0])]!r}, which --task "
                f"does not re-derive: validate it against its own record (without --task)"
            )
        raise HriplanError(f"the trajectory's step {trajectory.step!r} is not a step of task {runner.task.name!r}")
    session = runner._session()
    session.set_scene(step.scene)
    resolved = session.resolve(c.spec for c in step.derivation.constraints)
    return trajectory.model_copy(update={"constraints": _with_origins(resolved, step.derivation), "scene": step.scene})


def step_setting(runner: TaskRunner, name: str) -> MotionSetting:
    """Where a motion made elsewhere for task step `name` is checked, as `plan` would check its
    own: the step's scene, constraints (derived by the rules), ISO/TS 15066 policy and velocity
    scale. Nothing is planned, so the start is the task's start, and the joints of the arms an
    earlier step moves have no known start (a motion must give them)."""
    outcome = runner.run(plan=False)
    index = next((k for k, s in enumerate(outcome.steps) if s.name == name), None)
    if index is None:
        steps = ", ".join(s.name for s in outcome.steps)
        raise HriplanError(f"--step: task {runner.task.name!r} has no step {name!r}; its steps: {steps}")
    step, session = outcome.steps[index], runner._session()
    session.set_scene(step.scene)
    session.set_constraints(c.spec for c in step.derivation.constraints)
    robot = session.robot
    moved = frozenset(
        joint
        for done in outcome.steps[:index]
        for arm in done.arms
        for joint in robot.group_joints(robot.arm_group(arm))
    )
    derivation = step.derivation
    return session.setting(task_start(runner.task), derivation.velocity_scale, derivation.separation, moved)
