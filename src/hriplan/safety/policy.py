"""ISO/TS 15066 parameters from the ontology into the planner's `SeparationPolicy`.

The robot's stopping data sit on the robot individual, each person's approach parameters on the
`SeparationParameters` individual of their role, the power-and-force-limiting values on the
`BodyRegion`s that role offers for contact (on the person's handing side). A derived step reads
them from its reasoned facts; a bare planning problem reads the same ontology without
reasoning, with the roles the problem names (a person without one is a bystander).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

from hriplan import HriplanError
from hriplan.ontology.facts import Facts
from hriplan.ontology.schema import load_schema
from hriplan.ontology.situation import Situation
from hriplan.ontology.vocabulary import ontology_source
from hriplan.robots.human import HumanSpec, handing_hand
from hriplan.safety.separation import ContactRegion, PersonSeparation, RobotStopping, SeparationPolicy

PARAMETERS = "SeparationParameters"
DEFAULT_ROLE = "Bystander"  # a person without a role does not expect the robot


def separation_policy(facts: Facts, robot: str, people: Iterable[tuple[str, str, str]]) -> SeparationPolicy:
    """The policy for `robot` and `people` given as (name, role, handing side: left/right)."""
    if not facts.get(robot, "hasReactionTime"):  # a robot file without `stopping` (robot init writes none)
        raise HriplanError(
            f"robot {robot} has no ISO/TS 15066 stopping data: give its robot file 'stopping: {{reaction_time: s, "
            "stopping_time: s, position_uncertainty: m, moving_mass: kg}', as measured for the deployment"
        )
    stopping = RobotStopping(
        reaction_time=facts.number(robot, "hasReactionTime"),
        stopping_time=facts.number(robot, "hasStoppingTime"),
        position_uncertainty=facts.number(robot, "hasPositionUncertainty"),
        moving_mass=facts.number(robot, "hasMovingMass"),
    )
    by_role = {str(facts.one(i, "appliesToRole")): i for i, types in facts.types.items() if PARAMETERS in types}
    persons = []
    for name, role, side in people:
        if role not in by_role:
            raise HriplanError(f"the ontology has no SeparationParameters for role {role!r} (person {name})")
        individual = by_role[role]
        # Sorted: a set of regions, which the reasoner and the triples list in any order.
        contact = [_region(facts, r, side) for r in sorted(map(str, facts.get(individual, "offersContactWith")))]
        persons.append(
            PersonSeparation(
                name=name,
                role=role,
                approach_speed=facts.number(individual, "hasApproachSpeed"),
                intrusion=facts.number(individual, "hasIntrusionDistance"),
                sensor_uncertainty=facts.number(individual, "hasSensorUncertainty"),
                contact=contact,
            )
        )
    return SeparationPolicy(robot=stopping, people=persons)


def situation_policy(facts: Facts, situation: Situation) -> SeparationPolicy:
    """The policy for a reasoned situation: its robot, every person by their role and hand."""
    return separation_policy(
        facts, _robot_individual(facts, situation.robot), [(h.name, h.role, h.hand) for h in situation.humans]
    )


def _robot_individual(facts: Facts, urdf_name: str) -> str:
    """The ontology's individual for a robot (by its URDF name)."""
    robots = [
        i for i, types in facts.types.items() if "Robot" in types and urdf_name in map(str, facts.get(i, "hasUrdfName"))
    ]
    if not robots:
        raise HriplanError(f"the ontology describes no robot {urdf_name!r} (no Robot with hasUrdfName {urdf_name!r})")
    return robots[0]


def _region(facts: Facts, region: str, side: str) -> ContactRegion:
    return ContactRegion(
        region=region,
        capsules=[f"{side}_{segment}" for segment in sorted(map(str, facts.get(region, "coversSegment")))],
        spring_constant=facts.number(region, "hasSpringConstant"),
        effective_mass=facts.number(region, "hasEffectiveMass"),
        transient_force=facts.number(region, "hasQuasiStaticForce") * facts.number(region, "hasTransientFactor"),
    )


def default_policy(
    robot: str, people: Iterable[HumanSpec], roles: Mapping[str, str] | None = None, ontology: str | Path | None = None
) -> SeparationPolicy:
    """The policy of a bare planning problem from the ontology's values: each person by their
    role in `roles` (else a bystander), handing with the hand they reach out (else the right)."""
    roles = dict(roles or {})
    people = list(people)
    unknown = sorted(set(roles) - {p.name for p in people})
    if unknown:
        raise HriplanError(f"roles name {', '.join(unknown)}, who is not in the scene")
    handing = [(p.name, roles.get(p.name, DEFAULT_ROLE), handing_hand(p)) for p in people]
    facts = load_schema(ontology_source(ontology)).individuals  # told facts: no reasoning, no rdflib when cached
    return separation_policy(facts, _robot_individual(facts, robot), handing)
