"""The rules on example situations: each fires where it should and nowhere else, with the right
geometry, parameters from the ontology, and provenance; the result binds in the planner."""

import math
from pathlib import Path

import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.ontology.cache import ReasoningCache
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.situation import EXAMPLES_DIR, Situation, load_situation
from hriplan.ontology.vocabulary import ONTOLOGY_PATH
from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    CylinderConstraint,
    OrientationConstraint,
    SphereConstraint,
)
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.human import HumanSpec
from hriplan.robots.scene import Scene
from hriplan.rules.explain import explain
from hriplan.rules.geometry import bearing, box_between, rotation_with_axis
from hriplan.rules.infer import Derivation, DerivedConstraint, derive, infer_constraints

UR5_JOINTS = [f"{j}_joint" for j in ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")]
RIGHT_ARM = [f"right_{j}" for j in UR5_JOINTS]


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> ReasoningCache:
    return ReasoningCache(tmp_path_factory.getbasetemp() / "kb-cache")


@pytest.fixture(scope="module")
def derived(cache):
    """Derivation of an example situation by file stem, reasoned once per test session."""
    memo: dict[str, Derivation] = {}

    def get(name: str) -> Derivation:
        if name not in memo:
            memo[name] = derive(KnowledgeBase(situation(name), cache=cache))
        return memo[name]

    return get


def situation(name: str) -> Situation:
    return load_situation(EXAMPLES_DIR / f"{name}.json")


def constraints(derivation: Derivation) -> dict[str, DerivedConstraint]:
    return {c.spec.id: c for c in derivation.constraints}


def about(derivation: Derivation, anchor: str) -> list[str]:
    return [c.kind for c in derivation.constraints if c.anchor == anchor] + [
        v.kind for v in derivation.velocity if v.anchor == anchor
    ]


# -- 1. open containers stay upright ---------------------------------------------------------


def test_a_full_open_can_handed_over_stays_upright_with_the_tight_tolerance(derived):
    upright = constraints(derived("handover_can"))["upright_can1"]
    spec = upright.spec
    assert isinstance(spec, OrientationConstraint)
    assert (spec.joints, spec.target_link, spec.frame.entity) == (RIGHT_ARM, "right_tool", "world")
    assert spec.free_axes == ["y"] and spec.tolerance == 0.05 and spec.tolerance_gradient == 0.0
    np.testing.assert_allclose(spec.target.rotation()[:, 1], [0.0, 0.0, 1.0], atol=1e-12)  # tool y along world up
    assert upright.rules == ["upright_full_open_container", "define_full_open_container"]
    assert {"can1 is a Can", "can1 has fill level Full", "can1 is open", "handover moves can1"} <= set(upright.facts)


def test_a_partially_full_open_cup_gets_the_looser_tolerance_on_its_own_arm(derived):
    cup = constraints(derived("transport_hot_cup"))["right_upright_cup1"]
    assert cup.kind == "UprightPartial" and cup.spec.tolerance == 0.1 and cup.arm == "right"
    assert cup.rules == ["upright_partially_full_open_container", "define_partially_full_open_container"]


@pytest.mark.parametrize(
    ("name", "anchor", "why"),
    [
        ("transport_hot_cup", "bottle1", "closed"),
        ("handover_knife_glass", "glass4", "empty"),
        ("transport_knife_glass", "glass6", "empty"),
        ("pouring", "cup5", "pouring tilts it on purpose"),
    ],
)
def test_no_upright_for_closed_or_empty_containers_or_when_pouring(derived, name, anchor, why):
    assert not [k for k in about(derived(name), anchor) if k.startswith("Upright")], why


# -- 2. handover: approach cone, shared workspace, exclusion box -----------------------------


def test_a_handover_approaches_the_receivers_hand_inside_a_cone_opening_towards_the_robot(derived):
    cone = constraints(derived("handover_can"))["approach_cone_bob"]
    spec = cone.spec
    assert isinstance(spec, ConeConstraint) and spec.region == "inside"
    assert spec.frame.entity == "bob/right_hand"
    # bob faces the robot: the cone's axis (its frame's z) is the hand frame's x, apex at the palm
    np.testing.assert_allclose(spec.frame.offset.rotation()[:, 2], (1.0, 0.0, 0.0), atol=1e-9)
    np.testing.assert_allclose(spec.frame.offset.xyz, (0.0, 0.0, 0.0), atol=1e-9)
    assert (spec.radius, spec.height) == (0.3, 0.55)
    assert cone.rules == ["handover_approach_cone", "define_receiver"]
    assert cone.facts == [
        "handover is a RobotToHumanHandover",
        "handover has target human bob",
        "bob is a Human",
        "bob has role Receiver",
        "bob is a Receiver (derived)",
    ]


def test_a_handover_keeps_the_tool_in_a_box_between_robot_and_receiver(derived):
    spec = constraints(derived("handover_can"))["shared_workspace_bob"].spec
    assert isinstance(spec, BoxConstraint) and spec.region == "inside" and spec.frame.entity == "world"
    # from 0.3 m behind the base (0, 0) to 0.2 m before bob (0, 1.45), 1 m wide, 0.5 m to 1.6 m high
    np.testing.assert_allclose(spec.frame.offset.xyz, (0.0, 0.475, 1.05), atol=1e-9)
    np.testing.assert_allclose(spec.size, (1.55, 1.0, 1.1), atol=1e-9)
    np.testing.assert_allclose(spec.frame.offset.rpy, (0.0, 0.0, math.pi / 2), atol=1e-9)


def test_a_handover_keeps_robot_and_links_out_of_the_receivers_torso_and_head(derived):
    spec = constraints(derived("handover_can"))["exclusion_box_bob"].spec
    assert isinstance(spec, BoxConstraint) and spec.region == "outside" and spec.keep_out_all_links
    assert spec.frame.entity == "bob/torso" and spec.frame.offset.xyz == (0.0, 0.0, 0.25)
    assert spec.size == (0.4, 0.6, 1.1)


def test_with_two_arms_every_arm_gets_the_handover_constraints(derived):
    ids = set(constraints(derived("handover_knife_glass")))
    assert {
        f"{arm}_{c}_bob" for arm in ("right", "left") for c in ("approach_cone", "shared_workspace", "exclusion_box")
    } <= ids


def test_no_handover_constraints_without_a_handover(derived):
    kinds = {c.kind for c in derived("transport_hot_cup").constraints}
    assert not kinds & {"ApproachCone", "SharedWorkspaceBox", "ReceiverExclusionBox"}


# -- 3. supervisors and bystanders: keep-out cylinders ---------------------------------------


def test_a_supervisor_is_kept_out_of_reach_by_the_supervisor_distance(derived):
    keep_out = constraints(derived("handover_can"))["keep_out_sue"]
    spec = keep_out.spec
    assert isinstance(spec, CylinderConstraint) and spec.frame.entity == "sue/base"
    assert (spec.radius, spec.height, spec.region, spec.keep_out_all_links) == (0.5, 2.0, "outside", True)
    assert (
        keep_out.rules == ["keep_out_supervisor", "define_supervisor"] and "sue has role Supervisor" in keep_out.facts
    )


def test_a_bystander_gets_the_larger_distance_on_both_arms(derived):
    found = constraints(derived("transport_hot_cup"))
    assert found["right_keep_out_ann"].spec.radius == 0.8 and found["left_keep_out_ann"].spec.radius == 0.8
    head = found["right_keep_out_head_col"].spec  # a collaborator keeps only their head out of reach
    assert isinstance(head, SphereConstraint) and head.frame.entity == "col/head" and head.radius == 0.3


def test_no_keep_out_for_the_receiver_or_when_nobody_is_around(derived):
    assert about(derived("handover_can"), "bob") == ["ApproachCone", "ReceiverExclusionBox", "SharedWorkspaceBox"]
    assert derived("insertion_ur5").constraints[0].kind == "InsertionAlignment"
    assert len(derived("insertion_ur5").constraints) == 1


# -- 4. insertion: alignment with a dynamic tolerance ----------------------------------------


def test_a_peg_follows_the_holes_axis_with_a_tolerance_growing_from_the_goal(derived):
    alignment = constraints(derived("insertion_ur5"))["alignment_peg1"]
    spec = alignment.spec
    assert isinstance(spec, OrientationConstraint)
    assert spec.joints == UR5_JOINTS
    assert spec.target_link == "tool" and spec.free_axes == ["z"]
    assert (spec.tolerance, spec.tolerance_gradient) == (0.02, 0.3)
    hole_axis = situation("insertion_ur5").object("hole1").pose.rotation()[:, 2]  # tilted by 0.2 rad
    np.testing.assert_allclose(spec.target.rotation()[:, 2], -hole_axis, atol=1e-12)  # UR5: object z = tool -z
    assert alignment.rules == ["insertion_alignment"] and "peg1 goes into hole1" in alignment.facts


def test_no_alignment_outside_insertions(derived):
    for name in ("handover_can", "transport_hot_cup", "handover_knife_glass", "transport_knife_glass", "pouring"):
        assert not any(c.kind == "InsertionAlignment" for c in derived(name).constraints)


# -- 5. sharp tools point away from the receiver ---------------------------------------------


def test_a_knife_handed_over_points_away_from_the_receiver(derived):
    sharp = constraints(derived("handover_knife_glass"))["right_sharp_end_away_knife1"]
    spec = sharp.spec
    assert isinstance(spec, OrientationConstraint) and spec.frame.entity == "bob/base"
    np.testing.assert_allclose(spec.target.rotation()[:, 1], [1.0, 0.0, 0.0], atol=1e-12)  # bob's front: to the robot
    assert spec.free_axes == ["y"] and spec.tolerance == 0.5
    assert sharp.rules == ["sharp_end_away_from_receiver", "define_sharp_tool"]
    assert {"knife1 is a Knife", "knife1 is sharp", "knife1 is a SharpTool (derived)"} <= set(sharp.facts)


@pytest.mark.parametrize("name", ["transport_knife_glass", "handover_can"])
def test_no_sharp_end_rule_for_a_knife_not_handed_over_or_a_blunt_object(derived, name):
    assert not any(c.kind == "SharpEndAway" for c in derived(name).constraints)


def knife_near(*people: tuple[str, float, float]) -> Situation:
    """A knife carried by the right arm 0.8 m in front of MADAR (facing +y), collaborators at (x, y)."""
    return Situation.model_validate(
        {
            "task": {"name": "carry", "kind": "Transport", "arms": ["right"], "carries": {"knife": "right"}},
            "objects": [{"name": "knife", "kind": "Knife", "pose": {"xyz": [0.3, 0.8, 1.0]}, "grasp_axis": "+y"}],
            "humans": [{"name": n, "role": "Collaborator", "position": [x, y], "yaw": 0.0} for n, x, y in people],
        }
    )


def test_a_knife_carried_near_a_collaborator_points_down_and_away_from_him_at_half_speed(cache):
    derivation = derive(KnowledgeBase(knife_near(("col", 1.0, 1.5)), cache=cache))
    down = constraints(derivation)["sharp_end_down_knife"]
    spec = down.spec
    assert isinstance(spec, OrientationConstraint) and spec.frame.entity == "world" and spec.joints == RIGHT_ARM
    away = -np.array([1.0, 1.5]) / math.hypot(1.0, 1.5)  # from col towards the robot's base
    blade = math.cos(0.5) * np.array([0.0, 0.0, -1.0]) + math.sin(0.5) * np.append(away, 0.0)
    np.testing.assert_allclose(spec.target.rotation()[:, 1], blade, atol=1e-12)  # the knife's axis: tool +y
    assert spec.free_axes == ["y"] and spec.tolerance == 0.5 and spec.tolerance_gradient == 0.0
    assert down.rules[0] == "sharp_end_down_near_human" and "knife is near col" in down.facts
    (slow,) = derivation.velocity
    assert (slow.kind, slow.anchor, slow.value, derivation.velocity_scale) == (
        "ReducedVelocitySharp",
        "knife",
        0.5,
        0.5,
    )
    assert slow.rules[0] == "slow_sharp_tool_near_human"


def test_a_knife_between_two_people_on_either_side_points_straight_down(cache):
    derivation = derive(KnowledgeBase(knife_near(("a", 0.5, 0.0), ("b", -0.5, 0.0)), cache=cache))
    spec = constraints(derivation)["sharp_end_down_knife"].spec
    np.testing.assert_allclose(spec.target.rotation()[:, 1], [0.0, 0.0, -1.0], atol=1e-12)


def test_no_sharp_end_down_for_a_knife_far_from_people_handed_over_or_about_to_be_grasped_or_a_cup(derived, cache):
    far = derive(KnowledgeBase(knife_near(("col", 3.0, 2.0)), cache=cache))
    grasping = knife_near(("col", 1.0, 1.5)).model_copy(deep=True)
    grasping.task.carries = {}  # the hand on its way to the knife is empty
    cup = derived("transport_hot_cup")  # a blunt cup carried near col
    for derivation in (far, derived("handover_knife_glass"), derive(KnowledgeBase(grasping, cache=cache)), cup):
        assert not any(c.kind == "SharpEndDown" for c in derivation.constraints)
        assert not any(v.kind == "ReducedVelocitySharp" for v in derivation.velocity)


# -- 6. fragile or hot objects near people: reduced velocity ---------------------------------


def test_a_hot_cup_near_a_person_halves_the_velocity(derived):
    derivation = derived("transport_hot_cup")
    (hot,) = derivation.velocity
    assert (hot.kind, hot.anchor, hot.value, derivation.velocity_scale) == ("ReducedVelocityHot", "cup1", 0.5, 0.5)
    assert hot.rules == ["slow_hot_object_near_human", "define_hot_object", "carried_object_near_human"]
    cup, col = situation("transport_hot_cup").object("cup1"), situation("transport_hot_cup").human("col")
    distance = math.dist(cup.pose.xyz[:2], col.position)  # nearness is computed from the geometry, not by a rule
    assert {"cup1 is hot", "cup1 is near col", f"cup1 is {distance:.2f} m from col, below NearHuman 1.2 m"} <= set(
        hot.facts
    )


def test_a_glass_handed_over_is_fragile_near_its_receiver(derived):
    (fragile,) = derived("handover_knife_glass").velocity
    assert (fragile.kind, fragile.anchor, fragile.value) == ("ReducedVelocityFragile", "glass4", 0.5)
    assert "handover_object_near_partner" in fragile.rules
    assert "glass4 is a FragileObject (derived)" in fragile.facts  # no one said so: every glass is fragile


@pytest.mark.parametrize("name", ["handover_can", "transport_knife_glass"])
def test_full_speed_when_nothing_fragile_or_hot_moves_near_someone(derived, name):
    derivation = derived(name)  # handover_can: glass1 is near bob but stays put; transport: nobody around
    assert derivation.velocity == [] and derivation.velocity_scale == 1.0


# -- parameters, provenance, output -----------------------------------------------------------


def test_parameters_come_from_the_ontology_file(tmp_path, cache):
    text = ONTOLOGY_PATH.read_text()
    changed = text.replace(
        'hp:hasIdPrefix "upright" ; hp:hasTolerance 0.05 ;', 'hp:hasIdPrefix "upright" ; hp:hasTolerance 0.07 ;'
    )
    changed = changed.replace("hp:hasSeparationDistance 0.5 ;", "hp:hasSeparationDistance 0.9 ;")
    assert changed.count("0.07") == text.count("0.07") + 1 and "hasSeparationDistance 0.9" in changed
    ontology = tmp_path / "hriplan.ttl"
    ontology.write_text(changed)
    found = {c.spec.id: c.spec for c in infer_constraints(situation("handover_can"), ontology=ontology, cache=cache)}
    assert found["upright_can1"].tolerance == 0.07
    assert found["keep_out_sue"].radius == 0.9


def test_a_parameter_the_planner_refuses_names_the_kind(tmp_path, cache):
    ontology = tmp_path / "hriplan.ttl"
    ontology.write_text(ONTOLOGY_PATH.read_text().replace("hp:hasRadius 0.3 ;", "hp:hasRadius -0.3 ;"))
    with pytest.raises(
        HriplanError, match=r"constraint kind ApproachCone: radius: Input should be greater than 0 \(check its"
    ):
        infer_constraints(situation("handover_can"), ontology=ontology, cache=cache)


def test_explain_says_what_each_constraint_does_and_why(derived):
    derivation = derived("transport_hot_cup")
    text = explain(derivation)
    assert "right_upright_cup1 (arm right): right_tool stays within 0.1 rad of its target orientation in world" in text
    assert "rules: upright_partially_full_open_container, define_partially_full_open_container" in text
    assert "facts: transport is a Transport; transport moves cup1; cup1 is a Cup; cup1 has fill level Partial" in text
    assert "velocity scale 0.5 while moving cup1" in text and text.endswith("velocity scale for the trajectory: 0.5")
    keep_out = explain(constraints(derivation)["left_keep_out_ann"])
    assert keep_out.splitlines()[0] == (
        "left_keep_out_ann (arm left): left_tool stays outside a cylinder of radius 0.8 m "
        "and height 2 m standing at ann/base (and so does every robot link)"
    )
    assert "why: A bystander does not expect the robot at all" in keep_out


def test_the_derivation_round_trips_through_json(derived):
    derivation = derived("handover_knife_glass")
    assert Derivation.model_validate_json(derivation.model_dump_json()) == derivation
    assert [c.id for c in derivation.constraint_set().constraints] == [c.spec.id for c in derivation.constraints]


def test_two_kinds_making_the_same_constraint_is_an_error(tmp_path, cache):
    rules = tmp_path / "both.rules"
    rules.write_text(
        "# Contradicts the package rule on purpose.\n"
        "[also_partial] TransportingTask(?t) ^ movesObject(?t, ?o) ^ Can(?o) -> isConstrainedBy(?o, UprightPartial)\n"
    )
    with pytest.raises(
        HriplanError, match="UprightFull and UprightPartial both make constraint 'upright_can1' for can1"
    ):
        infer_constraints(situation("handover_can"), rule_files=[rules], cache=cache)


@pytest.mark.parametrize("name", ["handover_can", "handover_knife_glass", "transport_hot_cup"])
def test_the_planner_accepts_the_constraints(madar, derived, name):
    people = [HumanSpec(**h.model_dump(exclude={"role", "hand"})) for h in situation(name).humans]
    bound = bind(derived(name).constraint_set().constraints, madar, CollisionChecker(madar, Scene(humans=people)))
    assert len(bound) == len(derived(name).constraints)
    for constraint in bound:
        if isinstance(constraint.spec, ConeConstraint):  # the cone opens from the hand towards the robot's base
            towards_robot = -constraint.frame.translation[:2] / np.linalg.norm(constraint.frame.translation[:2])
            assert constraint.frame.rotation[:2, 2] @ towards_robot > 0.9


# -- geometry ---------------------------------------------------------------------------------


@pytest.mark.parametrize("axis", ["+x", "-x", "+y", "-y", "+z", "-z"])
@pytest.mark.parametrize("direction", [(0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (0.3, -0.2, 0.9)])
def test_rotation_with_axis_is_a_rotation_with_that_column(axis, direction):
    rotation = rotation_with_axis(axis, np.array(direction))
    np.testing.assert_allclose(rotation.T @ rotation, np.eye(3), atol=1e-12)
    assert np.linalg.det(rotation) == pytest.approx(1.0)
    sign = -1.0 if axis[0] == "-" else 1.0
    np.testing.assert_allclose(
        rotation[:, "xyz".index(axis[1])], sign * np.array(direction) / np.linalg.norm(direction)
    )


def test_upright_target_for_madar_matches_the_documented_convention():
    np.testing.assert_allclose(
        rotation_with_axis("+y", np.array([0.0, 0.0, 1.0])), [[-1, 0, 0], [0, 0, 1], [0, 1, 0]], atol=1e-12
    )


def test_bearing_and_box_geometry():
    assert bearing((1.0, 0.0), math.pi, (0.0, 0.0), "bob") == pytest.approx(0.0)  # facing the robot
    assert bearing((1.0, 0.0), 0.0, (0.0, 0.0), "bob") == pytest.approx(math.pi)  # back to the robot
    assert bearing((0.0, 1.0), 0.0, (0.0, 0.0), "bob") == pytest.approx(-math.pi / 2)
    with pytest.raises(HriplanError, match="bob stands on the robot's base"):
        bearing((0.0, 0.0), 0.0, (0.0, 0.0), "bob")
    with pytest.raises(HriplanError, match="bob stands 0.10 m from the robot's base: too close"):
        box_between((0.0, 0.0), (0.1, 0.0), 0.0, 0.2, 1.0, 0.5, 1.5, "bob")


def test_every_example_situation_loads():
    examples = {p.stem: load_situation(p) for p in Path(EXAMPLES_DIR).glob("*.json")}
    assert set(examples) == {
        "handover_can",
        "handover_knife_glass",
        "insertion_ur5",
        "pouring",
        "transport_hot_cup",
        "transport_knife_glass",
    }
