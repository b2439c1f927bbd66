"""A symbolic task planner (unified-planning, with pyperplan as its engine) that asks hriplan
whether each of the robot's grounded actions can be done before it plans.

MADAR holds a full, open cup (examples/task_planner/deliver_cup.yaml); alice asked for it. There are
two ways to deliver it: hand it to her (one action), or put it on the table beside her and let
her take it (two actions, the second hers). pyperplan finds the shortest plan among the actions
allowed, and an action is allowed only if hriplan's `feasible` says so: its constraints derived
by the rules, its motion planned, validated and timed. Both robot actions start from the world as
it is (the robot holds the cup), so each is asked about once, in that state.

Twice: with bob far off the handover is feasible and chosen; with bob beside alice's hand every
way to reach it enters his keep-out volume, hriplan says so, and the planner puts the cup down.

Run: .venv/bin/python examples/task_planner_handover.py
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import unified_planning.shortcuts as up
from unified_planning.engines import PlanGenerationResultStatus

from hriplan.api import Feasibility, HumanSpec, PlanningSession, Step, feasible, load_task

EXAMPLES = Path(__file__).parent
WORLD = EXAMPLES / "task_planner" / "deliver_cup.yaml"
# Where the robot would put each object down on each table (world frame, m): a grounded place.
SPOTS = {("cup", "table"): (0.5, 0.8, 0.77)}
BOB_AWAY = HumanSpec(name="bob", position=(1.4, -0.3), yaw=3.1416)
BOB_BESIDE_ALICE = HumanSpec(name="bob", position=(-0.25, 1.4), yaw=1.5708)

up.get_environment().credits_stream = None  # no engine banner in the output


@dataclass
class Choice:
    plan: list[str]  # the actions, as unified-planning writes them
    answers: dict[str, Feasibility]  # hriplan's answer for each grounded robot action


def robot_steps(objects: list[str], people: list[str], tables: list[str]) -> dict[str, Step]:
    """Each grounded robot action (as the planner writes it) as the task step hriplan plans."""
    steps = {
        f"hand_over({obj}, {person})": Step(name=f"hand_over_{obj}_to_{person}", goal={"hand_over": obj, "to": person})
        for obj in objects
        for person in people
    }
    steps |= {
        f"place({obj}, {where})": Step(
            name=f"place_{obj}_on_{where}", goal={"place": obj, "at": {"xyz": SPOTS[obj, where]}}
        )
        for obj in objects
        for where in tables
        if (obj, where) in SPOTS
    }
    return steps


def deliver(session: PlanningSession) -> Choice:
    """Ask hriplan about every grounded robot action, then plan with only the feasible ones."""
    world = load_task(WORLD)
    objects, people = [o.name for o in world.objects], [h.name for h in world.humans]
    tables = [t.name for t in world.scene.tables]
    answers = {
        action: feasible(session, world, step, EXAMPLES)
        for action, step in robot_steps(objects, people, tables).items()
    }

    Item, Person, Table = up.UserType("Item"), up.UserType("Person"), up.UserType("Table")
    holds = up.Fluent("robot_holds", up.BoolType(), i=Item)
    on = up.Fluent("on", up.BoolType(), i=Item, t=Table)
    has = up.Fluent("has", up.BoolType(), p=Person, i=Item)
    can_hand = up.Fluent("hriplan_can_hand_over", up.BoolType(), i=Item, p=Person)
    can_place = up.Fluent("hriplan_can_place", up.BoolType(), i=Item, t=Table)

    hand_over = up.InstantaneousAction("hand_over", i=Item, p=Person)
    i, p = hand_over.parameters
    hand_over.add_precondition(holds(i))
    hand_over.add_precondition(can_hand(i, p))
    hand_over.add_effect(holds(i), False)
    hand_over.add_effect(has(p, i), True)

    place = up.InstantaneousAction("place", i=Item, t=Table)
    i, t = place.parameters
    place.add_precondition(holds(i))
    place.add_precondition(can_place(i, t))
    place.add_effect(holds(i), False)
    place.add_effect(on(i, t), True)

    take = up.InstantaneousAction("take_from_table", p=Person, i=Item, t=Table)  # the person's own action
    p, i, t = take.parameters
    take.add_precondition(on(i, t))
    take.add_effect(on(i, t), False)
    take.add_effect(has(p, i), True)

    problem = up.Problem("deliver_cup")
    for fluent in (holds, on, has, can_hand, can_place):
        problem.add_fluent(fluent, default_initial_value=False)
    problem.add_actions([hand_over, place, take])
    named = {
        name: up.Object(name, kind)
        for names, kind in ((objects, Item), (people, Person), (tables, Table))
        for name in names
    }
    problem.add_objects(list(named.values()))
    for obj in world.objects:
        if obj.holding_arm is not None:
            problem.set_initial_value(holds(named[obj.name]), True)
    for action, answer in answers.items():
        verb, args = action.rstrip(")").split("(")
        fluent = can_hand if verb == "hand_over" else can_place
        problem.set_initial_value(fluent(*(named[a] for a in args.split(", "))), answer.ok)
    problem.add_goal(has(named["alice"], named["cup"]))

    with up.OneshotPlanner(name="pyperplan") as planner:
        result = planner.solve(problem)
    if result.status not in (
        PlanGenerationResultStatus.SOLVED_SATISFICING,
        PlanGenerationResultStatus.SOLVED_OPTIMALLY,
    ):
        return Choice(plan=[], answers=answers)
    return Choice(plan=[str(a) for a in result.plan.actions], answers=answers)


def report(title: str, choice: Choice) -> None:
    print(f"== {title}")
    for action, answer in choice.answers.items():
        if answer.ok:
            kinds = ", ".join(sorted({c.kind for c in answer.constraints}))
            print(f"  {action}: feasible, {answer.cost:.2f} s of motion; constraints: {kinds}")
        else:
            print(f"  {action}: infeasible ({answer.status}): {answer.reason}")
    print(f"  plan: {'; '.join(choice.plan) or 'none'}")
    refused = [action for action, answer in choice.answers.items() if not answer.ok]
    allowed = f"without {', '.join(refused)}, which hriplan refused" if refused else "every robot action allowed"
    print(f"  why: pyperplan's shortest plan, {allowed}")


def main() -> None:
    world = load_task(WORLD)
    session = PlanningSession(world.robot, hands=dict(world.hands))
    for title, bob in (("bob is far off", BOB_AWAY), ("bob stands beside alice's hand", BOB_BESIDE_ALICE)):
        session.set_scene(session.checker.scene.model_copy(update={"humans": [bob]}))  # what perception sees
        report(title, deliver(session))


if __name__ == "__main__":
    main()
