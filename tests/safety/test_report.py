"""The speed-and-separation report from positions and velocities alone (no planner, no robot):
a scripted monitor gives each point's samples, and the trace's summaries are worked by hand."""

import math
from types import SimpleNamespace

import pytest

from hriplan.safety.approach import PersonSample
from hriplan.safety.report import separation_report
from hriplan.safety.separation import PersonSeparation, RobotStopping

ROBOT = RobotStopping(reaction_time=0.1, stopping_time=0.3, position_uncertainty=0.02, moving_mass=10.0)
ANN = PersonSeparation(name="ann", role="Observer", approach_speed=1.6, intrusion=0.1, sensor_uncertainty=0.05)


def _sample(separation, allowed, approach):
    return PersonSample(separation, separation + 0.1, allowed, allowed, approach, math.inf, "wrist", "ann/head")


# Per point (its position is the point's index): far (no moving part faces her), approaching
# fast where much is allowed, approaching slowly where little is, moving away, at rest (the end
# of a motion: its speed towards her is rounding noise, not an approach).
SAMPLES = [
    _sample(math.inf, math.inf, 0.0),
    _sample(0.9, 1.0, 0.6),
    _sample(0.7, 0.4, 0.3),
    _sample(0.8, 0.2, -0.5),
    _sample(0.75, 0.1, 7e-17),
]


def test_the_trace_summarises_each_point_as_worked_by_hand():
    monitor = SimpleNamespace(
        people=[ANN],
        policy=SimpleNamespace(robot=ROBOT),
        samples_along=lambda xs, vs: [[SAMPLES[int(x[0])]] for x in xs],
    )
    (trace,) = separation_report(monitor, [[k] for k in range(5)], [[0.0]] * 5)
    assert (trace.person, trace.role, trace.contact_speed) == ("ann", "Observer", None)
    assert trace.minimum_separation == pytest.approx(1.6 * 0.4 + 0.1 + 0.05 + 0.02)  # v_h (T_r + T_s) + C + Z_d + Z_r
    assert trace.min_separation == 0.7
    assert trace.worst_margin == pytest.approx(0.1)  # 0.4 - 0.3; moving away (0.2 + 0.5) is no margin's minimum
    # The slowest allowed speed where she is approached: 0.4 m/s at 0.7 m, not the 0.2 m/s moving away
    # nor the 0.1 m/s at rest.
    assert (trace.slowest_allowed, trace.slowest_separation) == (0.4, 0.7)
    assert trace.separation == [None, 0.9, 0.7, 0.8, 0.75] and trace.body_separation[0] is None
    assert trace.allowed_speed == [None, 1.0, 0.4, 0.2, 0.1]
    assert trace.approach_speed == [None, 0.6, 0.3, -0.5, 7e-17]
