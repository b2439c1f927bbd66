"""The posable human: floor contact, reaching, seated posture, named frames."""

import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.robots.human import Human, HumanSpec


@pytest.fixture(scope="module")
def human():
    return Human(HumanSpec(position=(1.5, 0.3), yaw=np.pi))


def lowest_point(human):
    return min(
        p.translation[2] - abs(p.rotation[2, 2]) * c.length / 2 - c.radius
        for c, p in zip(human.capsules, human.capsule_placements())
    )


def test_standing_person_stands_on_the_floor_where_placed(human):
    human.pose(HumanSpec(position=(1.5, 0.3), yaw=np.pi))
    assert lowest_point(human) == pytest.approx(0.0, abs=1e-9)
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


def test_seated_person_is_lower(human):
    human.pose(HumanSpec(position=(1.5, 0.3), yaw=np.pi, posture="seated"))
    seated = human.frame("head").translation[2]
    human.pose(HumanSpec(position=(1.5, 0.3), yaw=np.pi))
    assert human.frame("head").translation[2] - seated > 0.3
    with pytest.raises(HriplanError, match="no frame 'knee'"):
        human.frame("knee")
