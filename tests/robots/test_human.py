"""The posable human: floor contact, reaching, seated posture, named frames."""

import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.recent import Recent
from hriplan.robots import human as human_module
from hriplan.robots.human import REACH_JOINTS, Human, HumanSpec, person_frame


@pytest.fixture(scope="module")
def human():
    return Human(HumanSpec(position=(1.5, 0.3), yaw=np.pi))


def lowest_capsule_point(human):
    return min(
        p.translation[2] - abs(p.rotation[2, 2]) * c.length / 2 - c.radius
        for c, p in zip(human.capsules, human.capsule_placements())
    )


def lowest_mesh_point(human):
    """The lowest vertex of the person's body meshes, posed here from the loader's own visual model
    with pinocchio (not hriplan's fitted data)."""
    import coal
    import pinocchio as pin
    from example_robot_data.human import HumanLoader

    from hriplan.robots.assets import resolve_package_uri

    loader = HumanLoader()
    model, visual = loader.robot.model, loader.robot.visual_model
    data, geometry = model.createData(), visual.createData()
    pin.forwardKinematics(model, data, human.q)
    pin.updateGeometryPlacements(model, data, visual, geometry)
    lowest = np.inf
    for g, placement in zip(visual.geometryObjects, geometry.oMg):
        mesh = coal.MeshLoader().load(resolve_package_uri(g.meshPath), np.asarray(g.meshScale))
        world = np.asarray(mesh.vertices()) @ placement.rotation.T + placement.translation
        lowest = min(lowest, float(world[:, 2].min()))
    return lowest


@pytest.mark.parametrize("posture", ["standing", "seated"])
def test_a_person_stands_on_the_floor_where_placed(human, posture):
    """The soles on the floor (they floated 6.6 cm above it, the foot capsules' bottom on it);
    the capsules, which contain the meshes, reach below it."""
    human.pose(HumanSpec(position=(1.5, 0.3), yaw=np.pi, posture=posture))
    assert lowest_mesh_point(human) == pytest.approx(0.0, abs=5e-3)
    assert lowest_capsule_point(human) < 0.0
    assert np.allclose(human.frame("base").translation, (1.5, 0.3, 0.0))


def test_standing_person_is_where_placed(human):
    human.pose(HumanSpec(position=(1.5, 0.3), yaw=np.pi))
    head = human.frame("head").translation
    assert 1.55 < head[2] < 1.85 and np.allclose(head[:2], (1.5, 0.3), atol=0.05)
    # facing -x (yaw pi): the right hand is on the +y side
    assert human.frame("right_hand").translation[1] > human.frame("left_hand").translation[1]


def test_reaching_puts_the_palm_on_the_target(human):
    target = (1.1, 0.4, 1.1)
    human.pose(HumanSpec(position=(1.5, 0.3), yaw=np.pi, reach={"right": target}))
    assert np.linalg.norm(human.frame("right_hand").translation - target) < 1e-3
    with pytest.raises(HriplanError, match="cannot reach"):
        human.pose(HumanSpec(position=(1.5, 0.3), yaw=np.pi, reach={"right": (-2.0, 0.0, 1.0)}))


def test_a_reach_relative_to_the_body_moves_and_turns_with_the_person(human):
    """forward along the way they face, left to their left, up from the floor: the palm is there,
    and moving the person moves it by the same displacement (a world reach stays behind)."""
    body = {"right": {"forward": 0.4, "left": -0.15, "up": 1.05}}
    yaw = -np.pi / 2  # facing -y: their left is +x, their right -x
    human.pose(HumanSpec.model_validate({"position": (0.0, 1.45), "yaw": yaw, "reach": body}))
    palm = human.frame("right_hand").translation.copy()
    assert np.allclose(palm, (-0.15, 1.05, 1.05), atol=1e-3)
    for displacement in [(0.3, 0.0), (-0.2, 0.35), (0.1, -0.1)]:
        moved = (0.0 + displacement[0], 1.45 + displacement[1])
        human.pose(HumanSpec.model_validate({"position": moved, "yaw": yaw, "reach": body}))
        assert np.allclose(human.frame("right_hand").translation - palm, (*displacement, 0.0), atol=2e-3)
    # turned a quarter to their left (facing +x), the hand is 0.4 m ahead in +x and 0.15 m to -y
    human.pose(HumanSpec.model_validate({"position": (0.0, 1.45), "yaw": 0.0, "reach": body}))
    assert np.allclose(human.frame("right_hand").translation, (0.4, 1.45 - 0.15, 1.05), atol=1e-3)
    world = {"right": tuple(palm)}
    human.pose(HumanSpec(position=(0.3, 1.45), yaw=yaw, reach=world))
    assert np.allclose(human.frame("right_hand").translation, palm, atol=1e-3)


def test_seated_person_is_lower(human):
    human.pose(HumanSpec(position=(1.5, 0.3), yaw=np.pi, posture="seated"))
    seated = human.frame("head").translation[2]
    human.pose(HumanSpec(position=(1.5, 0.3), yaw=np.pi))
    assert human.frame("head").translation[2] - seated > 0.3
    with pytest.raises(HriplanError, match="no frame 'knee'"):
        human.frame("knee")


def test_person_frame_is_a_fresh_humans_frame_whatever_was_asked_before():
    """`person_frame` poses one kept Human per height: each answer must be a newly made Human's,
    also after other people, another height, and a spec whose reach fails."""
    specs = [
        HumanSpec(position=(1.5, 0.3), yaw=np.pi, reach={"right": (1.0, 0.2, 1.1)}),
        HumanSpec(position=(-0.4, 1.2), yaw=-1.0, posture="seated"),
        HumanSpec(position=(0.2, 1.4), yaw=-np.pi / 2, height=1.6, reach={"left": (0.25, 0.9, 1.0)}),
        HumanSpec(position=(1.5, 0.3), yaw=np.pi, reach={"right": (-2.0, 0.0, 1.0)}),  # out of reach
        HumanSpec(position=(0.9, -0.6), yaw=0.4),
        HumanSpec(position=(1.5, 0.3), yaw=np.pi, reach={"right": (1.0, 0.2, 1.1)}),
    ]
    for spec in specs:
        for name in Human.FRAMES:
            try:
                expected = Human(spec).frame(name).homogeneous
            except HriplanError:
                with pytest.raises(HriplanError, match="cannot reach"):
                    person_frame(spec, name)
                continue
            assert np.allclose(person_frame(spec, name).homogeneous, expected, atol=1e-12), (spec, name)


# Arm joints (REACH_JOINTS, per reaching side) as the posing code of 42ad56b solved them: the
# loop's arithmetic must stay the same (re-plans compare their trajectories bit for bit).
SOLVED_ARMS = [
    (
        {"position": (1.5, 0.3), "yaw": np.pi, "reach": {"right": (1.1, 0.4, 1.1)}},
        [0.14508875724778825, -0.1991569697708643, 0.11967117131005393, 1.3403990586407641, 0.003922034741184318],
    ),
    (
        {
            "position": (0.0, 1.45),
            "yaw": -1.5708,
            "posture": "seated",
            "reach": {
                "left": {"forward": 0.35, "left": 0.2, "up": 0.9},
                "right": {"forward": 0.5, "left": -0.1, "up": 1.3},
            },
        },
        [-0.6075942762116736, 2.4798363744018452, -0.3387931739581277, 1.991074997731668, -0.025246422936960455]
        + [1.956459492991581, -0.1627964062236491, 0.08509685397660469, 0.40229188127287313, 0.004466865756630979],
    ),
    (
        {"position": (0.2, -0.3), "yaw": 0.7, "reach": {"right": {"forward": -0.3, "left": -0.3, "up": 1.9}}},
        [-2.702601791242841, -0.13830981744772922, -1.2451402702964587, 0.5064336283166347, -0.0634456279514944],
    ),
]


@pytest.mark.parametrize(("spec", "arms"), SOLVED_ARMS)
def test_an_arm_is_solved_to_the_same_joint_values_as_before(human, monkeypatch, spec, arms):
    """Solved afresh (no configuration remembered), the reaching arms' joints are the ones the
    earlier posing code found, to the last bits."""
    monkeypatch.setattr(human_module, "_CONFIGURATIONS", Recent(4))
    spec = HumanSpec.model_validate(spec)
    human.pose(spec)
    solved = [human.q[human._iq(f"{side}_{joint}")] for side in spec.reach for joint in REACH_JOINTS]
    assert np.allclose(solved, arms, rtol=0.0, atol=1e-14)


def test_a_spec_that_cannot_be_posed_leaves_the_person_as_they_were(human):
    """Solving a reach out of range moves the body model through many postures: refused, the
    person's frames and capsules are where they stood before it was asked (a checker keeps a
    person posed as before without posing them again)."""
    human.pose(HumanSpec(position=(1.5, 0.3), yaw=np.pi, reach={"right": (1.1, 0.4, 1.1)}))
    frames = {name: human.frame(name).homogeneous for name in Human.FRAMES}
    capsules = [p.homogeneous for p in human.capsule_placements()]
    with pytest.raises(HriplanError, match="cannot reach"):
        human.pose(HumanSpec(position=(0.2, 0.3), yaw=1.0, reach={"left": (-2.0, 0.0, 1.0)}))
    assert all(np.array_equal(human.frame(name).homogeneous, frames[name]) for name in Human.FRAMES)
    assert all(np.array_equal(p.homogeneous, c) for p, c in zip(human.capsule_placements(), capsules))


# The receiver's right arm (REACH_JOINTS) as c5881fc solved it, from the second seed.
ARM_OF_THE_RECEIVER = [
    0.31483730672216537,
    -0.44047096464396046,
    0.18154209994452022,
    0.8525587439392281,
    0.006706736635695427,
]


def test_a_seed_that_stops_closing_in_is_left_early(human, monkeypatch):
    """The example receiver's reach (handover_full_can_receiver.yaml): from the hanging arm the
    damped steps swing between two distances ~0.3 and ~0.5 m off. That seed is left once it has
    not closed in for `_STALLED_AFTER` steps, not at step 40, and the next seed reaches: fewer
    steps, the same arm as the earlier code solved."""
    import pinocchio as pin

    monkeypatch.setattr(human_module, "_CONFIGURATIONS", Recent(4))
    steps, jacobian = [], pin.computeJointJacobian
    monkeypatch.setattr(pin, "computeJointJacobian", lambda *args: steps.append(1) or jacobian(*args))
    spec = HumanSpec(position=(0.1, 1.45), yaw=-1.5708, reach={"right": (0.15, 1.05, 1.05)})
    human.pose(spec)
    assert np.linalg.norm(human.frame("right_hand").translation - spec.reach_point("right")) < 1e-4
    solved = [human.q[human._iq(f"right_{joint}")] for joint in REACH_JOINTS]
    assert np.allclose(solved, ARM_OF_THE_RECEIVER, rtol=0.0, atol=1e-14)
    assert len(steps) <= 30  # 44 when the swinging seed was left at step 40


def test_a_seed_closing_in_slowly_near_the_target_is_not_left(human, monkeypatch):
    """An arm stretched up and out creeps towards the target by less than 1 % a step once it
    is within a few centimetres: that is not a stall, and leaving it there would refuse a reach
    the person can make (it ends 0.8 mm away, within the 1 cm a reach may miss by)."""
    monkeypatch.setattr(human_module, "_CONFIGURATIONS", Recent(4))
    spec = HumanSpec(position=(0.906, -0.713), yaw=1.774, reach={"right": (1.323, -0.588, 1.372)})
    human.pose(spec)
    assert np.linalg.norm(human.frame("right_hand").translation - spec.reach_point("right")) < 1e-3


@pytest.mark.parametrize(
    "spec",
    [
        HumanSpec(position=(0.23, -0.233), yaw=2.983, reach={"left": (0.131, -0.703, 1.667)}),  # up, behind
        HumanSpec(position=(-0.119, 0.909), yaw=0.0, reach={"left": (-0.302, 1.111, 1.481)}),  # over the head
    ],
)
def test_a_reach_the_first_postures_miss_is_reached_from_the_later_ones(human, monkeypatch, spec):
    """Points the arm reaches (made from arm joints within their limits) that the hanging, bent and
    raised starts all miss (c5881fc refused them, 1 cm and 14 cm short): a later start reaches."""
    monkeypatch.setattr(human_module, "_CONFIGURATIONS", Recent(4))
    human.pose(spec)
    side = next(iter(spec.reach))
    assert np.linalg.norm(human.frame(f"{side}_hand").translation - spec.reach_point(side)) < 1e-4
