"""Speed and separation (ISO/TS 15066): the parameters and the formulas, nothing geometric.

Speed and separation monitoring (SSM, ISO/TS 15066 5.5.4): at every instant the separation S
between the robot and a person must be at least the protective separation distance

    S_p(v_r) = S_h + S_r + S_s + C + Z_d + Z_r
             = v_h (T_r + T_s) + v_r T_r + v_r T_s / 2 + C + Z_d + Z_r

(S_s = v_r T_s / 2: stopping distance at constant deceleration over the stopping time). Solved
for v_r it gives the largest robot speed towards the person at separation S; it is 0 at the
minimum separation S_0 = v_h (T_r + T_s) + C + Z_d + Z_r and grows linearly beyond.

Power and force limiting (PFL, ISO/TS 15066 5.5.5 and Annex A.3.2), transient contact: where
contact is the task (a person's hand meeting the robot's hand), the relative speed is capped at
v_rel,max = F_max / sqrt(mu k), mu = (1/m_H + 1/m_R)^-1; v_rel is relative, so the robot's cap is
v_rel,max - v_h. Near that contact region the robot may move at max(SSM speed, that cap), so it
can meet the hand, but only at the PFL speed, in any direction (a transient contact may come
from any side, so there the part's whole speed counts, not only its speed towards the person).

hriplan does not time a motion exactly on these limits: a `SafetyMargin` pads every person's
separation (the speed limit is taken at the separation less the padding, so it falls to 0 at
S_0 + padding) and keeps every speed a factor below its cap (`kept_speeds`).

The numbers live in the ontology (hriplan.ttl, section "Speed and separation"), with their
sources; `hriplan.safety.policy` reads them into a `SeparationPolicy`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

# A timed sample may exceed its speed limit by this fraction (timing.py checks, validate re-checks).
SPEED_LIMIT_SLACK = 1e-2

Positive = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]


class RobotStopping(BaseModel):
    """How the robot reacts and stops, and how much mass it moves (per robot, from the ontology)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    reaction_time: NonNegative  # T_r (s): sensing + controller response
    stopping_time: NonNegative  # T_s (s): from the stop command to standstill
    position_uncertainty: NonNegative  # Z_r (m)
    moving_mass: Positive  # m_R (kg), Annex A.3.2: half the moving parts' mass + payload
    stopping_model: Literal["constant_deceleration"] = "constant_deceleration"  # S_s = v_r T_s / 2


class ContactRegion(BaseModel):
    """A body region where transient contact with the robot is intended (PFL, Annex A)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    region: str  # the ontology's body region, e.g. HandFingerRegion
    capsules: list[str]  # the person's body-model capsules it covers, e.g. right_hand
    spring_constant: Positive  # k (N/m)
    effective_mass: Positive  # m_H (kg)
    transient_force: Positive  # F_max for transient contact (N)


class PersonSeparation(BaseModel):
    """One person's SSM parameters (from their role) and the contact region they offer, if any."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str
    role: str = ""
    approach_speed: NonNegative  # v_h (m/s)
    intrusion: NonNegative  # C (m)
    sensor_uncertainty: NonNegative  # Z_d (m)
    contact: list[ContactRegion] = Field(default_factory=list)

    def contact_region(self, capsule: str) -> ContactRegion | None:
        """The contact region covering one of the person's capsules, if contact is intended there."""
        return next((c for c in self.contact if capsule in c.capsules), None)


class SafetyMargin(BaseModel):
    """What hriplan keeps beyond ISO/TS 15066's own limits, so that no motion is timed exactly on
    them: a padding on every person's separation (m) and a factor below every speed cap."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    padding: NonNegative = 0.05  # added to S_0; the speed limit is taken this much closer than measured
    speed_factor: Annotated[float, Field(gt=0.0, le=1.0)] = 0.95  # of the SSM and PFL speed caps

    def __str__(self) -> str:
        return f"padding {self.padding:g} m, speed factor {self.speed_factor:g}"


NO_MARGIN = SafetyMargin(padding=0.0, speed_factor=1.0)
"""ISO/TS 15066's limits exactly (a trajectory file written before margins were recorded)."""


class SeparationPolicy(BaseModel):
    """What the time parameterisation must respect near people (interface I5), with the margin kept."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    robot: RobotStopping
    people: list[PersonSeparation] = Field(default_factory=list)
    margin: SafetyMargin = Field(default_factory=SafetyMargin)

    def person(self, name: str) -> PersonSeparation | None:
        return next((p for p in self.people if p.name == name), None)


def minimum_separation(robot: RobotStopping, person: PersonSeparation) -> float:
    """S_0 = v_h (T_r + T_s) + C + Z_d + Z_r: the separation at which the robot must stand still."""
    human_travel = person.approach_speed * (robot.reaction_time + robot.stopping_time)
    return human_travel + person.intrusion + person.sensor_uncertainty + robot.position_uncertainty


def _robot_travel_per_speed(robot: RobotStopping) -> float:
    """(S_r + S_s) / v_r = T_r + T_s / 2 (constant deceleration over T_s)."""
    return robot.reaction_time + robot.stopping_time / 2.0


def protective_separation(robot: RobotStopping, person: PersonSeparation, robot_speed: float) -> float:
    """S_p(v_r): the separation needed for the robot, moving at `robot_speed` (m/s) towards the
    person, to stop before reaching them."""
    return minimum_separation(robot, person) + max(robot_speed, 0.0) * _robot_travel_per_speed(robot)


def ssm_speed_limit(robot: RobotStopping, person: PersonSeparation, separation: float) -> float:
    """The inverse of S_p: the largest robot speed towards the person at `separation` (m/s); 0 at
    and below the minimum separation. With T_r = T_s = 0 the robot could stop at once: no limit."""
    return float(_ssm(robot, person, np.array([separation]))[0])


def _ssm(robot: RobotStopping, person: PersonSeparation, separations: np.ndarray) -> np.ndarray:
    room = np.maximum(separations - minimum_separation(robot, person), 0.0)
    travel = _robot_travel_per_speed(robot)
    return room / travel if travel > 0.0 else np.where(room > 0.0, np.inf, 0.0)


def pfl_speed_limit(robot: RobotStopping, contact: ContactRegion) -> float:
    """v_rel,max = F_max / sqrt(mu k), mu = (1/m_H + 1/m_R)^-1 (ISO/TS 15066 Annex A.3.2, A.3.3)."""
    mu = 1.0 / (1.0 / contact.effective_mass + 1.0 / robot.moving_mass)
    return contact.transient_force / math.sqrt(mu * contact.spring_constant)


def contact_speed_limit(robot: RobotStopping, person: PersonSeparation, region: ContactRegion) -> float:
    """The robot's speed cap at the contact region: v_rel,max less the person's own approach
    speed v_h, since v_rel of Annex A is the relative speed of robot and body region (>= 0)."""
    return max(pfl_speed_limit(robot, region) - person.approach_speed, 0.0)


def allowed_speed(robot: RobotStopping, person: PersonSeparation, separation: float, capsule: str) -> float:
    """Speed towards the person's `capsule` allowed at `separation`: SSM, or where the capsule is
    in a contact region, the larger of SSM and that region's contact cap (so the hands can meet)."""
    return float(allowed_speeds(robot, person, np.array([separation]), [capsule])[0])


def allowed_speeds(
    robot: RobotStopping, person: PersonSeparation, separations: np.ndarray, capsules: Sequence[str]
) -> np.ndarray:
    """`allowed_speed` for many part-capsule pairs at once (timing evaluates thousands)."""
    return capped_speeds(robot, person, separations, contact_caps(robot, person, capsules))


def contact_caps(robot: RobotStopping, person: PersonSeparation, capsules: Sequence[str]) -> np.ndarray:
    """Per capsule: its contact region's speed cap, 0 where no contact is intended (SSM alone);
    looked up once for callers that evaluate the same capsules many times."""
    caps = {
        c: contact_speed_limit(robot, person, person.contact_region(c))
        for c in set(capsules)
        if person.contact_region(c)
    }
    return np.array([caps.get(c, 0.0) for c in capsules], dtype=float)


def capped_speeds(
    robot: RobotStopping, person: PersonSeparation, separations: np.ndarray, caps: np.ndarray
) -> np.ndarray:
    """`allowed_speeds` with each pair's `contact_caps` given (broadcast against `separations`)."""
    return np.maximum(_ssm(robot, person, np.asarray(separations, dtype=float)), caps)


def kept_separation(policy: SeparationPolicy, person: PersonSeparation) -> float:
    """S_0 + padding: the separation at which the speed hriplan allows falls to 0."""
    return minimum_separation(policy.robot, person) + policy.margin.padding


def kept_speeds(
    policy: SeparationPolicy, person: PersonSeparation, separations: np.ndarray, capsules: Sequence[str]
) -> np.ndarray:
    """The speeds hriplan allows: `allowed_speeds` at the separations less the padding, times the
    speed factor (what timing keeps and `hriplan validate` checks)."""
    return kept_capped_speeds(policy, person, separations, contact_caps(policy.robot, person, capsules))


def kept_capped_speeds(
    policy: SeparationPolicy, person: PersonSeparation, separations: np.ndarray, caps: np.ndarray
) -> np.ndarray:
    """`kept_speeds` with each pair's `contact_caps` given (broadcast against `separations`)."""
    closer = np.asarray(separations, dtype=float) - policy.margin.padding
    return policy.margin.speed_factor * capped_speeds(policy.robot, person, closer, caps)


def kept_speed_terms(policy: SeparationPolicy, person: PersonSeparation) -> tuple[float, float, float, float]:
    """(padding, S_0, T_r + T_s / 2, speed factor): the numbers `kept_capped_speeds` computes
    from, for compiled code that evaluates it row by row (`approach_kernels._kept`, held to it
    by the tests)."""
    travel = _robot_travel_per_speed(policy.robot)
    return policy.margin.padding, minimum_separation(policy.robot, person), travel, policy.margin.speed_factor
