"""ISO/TS 15066 formulas (SSM 5.5.4, PFL Annex A.3.2) written out here, against separation.py, and
their invariants (hypothesis): S_p grows with the robot's speed, the allowed speed is 0 at or below
S_0 and grows with the separation, and S_p inverts the speed limit."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from hypothesis import Phase, given, settings
from hypothesis import strategies as st

from hriplan.safety import separation as S

# Reproducible and short; `make mutation` runs each property on fewer examples (many mutants).
settings.register_profile("ci", max_examples=200, deadline=None, derandomize=True)
settings.register_profile(
    "mutation", max_examples=25, deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate]
)
settings.load_profile(os.environ.get("HRIPLAN_HYPOTHESIS_PROFILE", "ci"))

small = st.floats(0.0, 1.0)
times = st.floats(0.0, 0.5)
speeds = st.floats(0.0, 3.0)
separations = st.floats(-0.5, 3.0)


@st.composite
def robots(draw, moving: bool = True) -> S.RobotStopping:
    return S.RobotStopping(
        reaction_time=draw(st.floats(0.01, 0.5) if moving else times),
        stopping_time=draw(times),
        position_uncertainty=draw(st.floats(0.0, 0.1)),
        moving_mass=draw(st.floats(0.5, 50.0)),
    )


@st.composite
def people(draw) -> S.PersonSeparation:
    hand = S.ContactRegion(
        region="HandFingerRegion",
        capsules=["right_hand"],
        spring_constant=draw(st.floats(1e3, 2e5)),
        effective_mass=draw(st.floats(0.1, 40.0)),
        transient_force=draw(st.floats(10.0, 500.0)),
    )
    return S.PersonSeparation(
        name="p",
        approach_speed=draw(st.floats(0.0, 2.0)),
        intrusion=draw(st.floats(0.0, 0.9)),
        sensor_uncertainty=draw(st.floats(0.0, 0.1)),
        contact=[hand],
    )


def s0(r: S.RobotStopping, p: S.PersonSeparation) -> float:
    """S_0 = S_h + C + Z_d + Z_r, S_h = v_h (T_r + T_s)."""
    return (
        p.approach_speed * (r.reaction_time + r.stopping_time)
        + p.intrusion
        + p.sensor_uncertainty
        + (r.position_uncertainty)
    )


def sp(r: S.RobotStopping, p: S.PersonSeparation, v_r: float) -> float:
    """S_p = S_h + S_r + S_s + C + Z_d + Z_r, S_r = v_r T_r, S_s = v_r T_s / 2."""
    return s0(r, p) + v_r * r.reaction_time + v_r * r.stopping_time / 2.0


def v_rel_max(r: S.RobotStopping, c: S.ContactRegion) -> float:
    """F_max / sqrt(mu k), mu = (1/m_H + 1/m_R)^-1."""
    mu = 1.0 / (1.0 / c.effective_mass + 1.0 / r.moving_mass)
    return c.transient_force / math.sqrt(mu * c.spring_constant)


@given(r=robots(), p=people(), v=speeds)
def test_the_protective_separation_is_the_standards_sum(r, p, v):
    assert S.minimum_separation(r, p) == pytest.approx(s0(r, p), rel=1e-12, abs=1e-15)
    assert S.protective_separation(r, p, v) == pytest.approx(sp(r, p, v), rel=1e-12, abs=1e-15)
    assert S.protective_separation(r, p, -v) == pytest.approx(s0(r, p))  # moving away needs no more than S_0


@given(r=robots(), p=people(), v=speeds, dv=st.floats(1e-3, 1.0))
def test_the_protective_separation_grows_with_the_robots_speed(r, p, v, dv):
    assert S.protective_separation(r, p, v + dv) > S.protective_separation(r, p, v)


@given(r=robots(), p=people(), below=st.floats(0.0, 1.0))
def test_the_allowed_speed_is_zero_at_and_below_the_minimum_separation(r, p, below):
    assert S.ssm_speed_limit(r, p, s0(r, p) - below) == 0.0
    assert S.allowed_speed(r, p, s0(r, p) - below, "head") == 0.0


@given(r=robots(), p=people(), s=separations, ds=st.floats(1e-3, 1.0))
def test_the_allowed_speed_grows_with_the_separation(r, p, s, ds):
    assert S.ssm_speed_limit(r, p, s + ds) >= S.ssm_speed_limit(r, p, s)
    if s > s0(r, p):
        assert S.ssm_speed_limit(r, p, s + ds) > S.ssm_speed_limit(r, p, s)


@given(r=robots(), p=people(), room=st.floats(1e-3, 2.0))
def test_the_speed_limit_is_the_speed_whose_protective_separation_is_the_separation(r, p, room):
    v = S.ssm_speed_limit(r, p, s0(r, p) + room)
    assert v == pytest.approx(room / (r.reaction_time + r.stopping_time / 2.0))
    assert S.protective_separation(r, p, v) == pytest.approx(s0(r, p) + room)


@given(r=robots(moving=False), p=people(), room=st.floats(1e-3, 2.0))
def test_a_robot_that_stops_at_once_has_no_limit_beyond_s0(r, p, room):
    r = r.model_copy(update={"reaction_time": 0.0, "stopping_time": 0.0})
    assert S.ssm_speed_limit(r, p, s0(r, p) + room) == math.inf
    assert S.ssm_speed_limit(r, p, s0(r, p)) == 0.0


@given(r=robots(), p=people())
def test_the_contact_cap_is_the_pfl_speed_less_the_persons_speed(r, p):
    hand = p.contact[0]
    assert S.pfl_speed_limit(r, hand) == pytest.approx(v_rel_max(r, hand), rel=1e-12)
    assert S.contact_speed_limit(r, p, hand) == pytest.approx(max(v_rel_max(r, hand) - p.approach_speed, 0.0))


def test_the_pfl_speed_of_the_hand_from_the_annex_values():
    """k = 75 N/mm, m_H = 0.6 kg, F_max = 280 N (transient), m_R = 10 kg: 280 / sqrt(0.566 * 75000)."""
    r = S.RobotStopping(reaction_time=0.1, stopping_time=0.2, position_uncertainty=0.0, moving_mass=10.0)
    hand = S.ContactRegion(
        region="HandFingerRegion", capsules=["h"], spring_constant=75e3, effective_mass=0.6, transient_force=280.0
    )
    assert S.pfl_speed_limit(r, hand) == pytest.approx(280.0 / math.sqrt((1 / (1 / 0.6 + 1 / 10.0)) * 75e3))


@given(r=robots(), p=people(), seps=st.lists(separations, min_size=1, max_size=6))
def test_the_allowed_speeds_are_ssm_or_at_the_hand_the_larger_of_ssm_and_the_contact_cap(r, p, seps):
    capsules = ["right_hand" if i % 2 else "torso" for i in range(len(seps))]
    got = S.allowed_speeds(r, p, np.array(seps), capsules)
    cap = max(v_rel_max(r, p.contact[0]) - p.approach_speed, 0.0)
    for s, c, v in zip(seps, capsules, got):
        ssm = max(s - s0(r, p), 0.0) / (r.reaction_time + r.stopping_time / 2.0)
        assert v == pytest.approx(max(ssm, cap) if c == "right_hand" else ssm)
        assert S.allowed_speed(r, p, s, c) == pytest.approx(v)


def test_policy_lookups_name_people_and_contact_regions():
    r = S.RobotStopping(reaction_time=0.1, stopping_time=0.2, position_uncertainty=0.0, moving_mass=10.0)
    hand = S.ContactRegion(
        region="H", capsules=["l", "r"], spring_constant=1.0, effective_mass=1.0, transient_force=1.0
    )
    ann = S.PersonSeparation(name="ann", approach_speed=1.6, intrusion=0.0, sensor_uncertainty=0.0, contact=[hand])
    policy = S.SeparationPolicy(robot=r, people=[ann])
    assert policy.person("ann") is ann and policy.person("bob") is None
    assert ann.contact_region("r") is hand and ann.contact_region("torso") is None
