"""A posable human from example-robot-data's articulated `human` model, with capsule geometry.

Each body segment gets one capsule that contains its display mesh (plus an optional safety
margin). Re-posing (standing / seated, base pose, an arm reaching to a point) only moves these
capsules: nothing on the robot side is rebuilt.
"""

from __future__ import annotations

import functools
import math
import threading
from dataclasses import dataclass
from typing import Annotated, Literal, TypeVar

import coal
import numpy as np
import pinocchio as pin
from example_robot_data.human import HumanLoader
from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, model_validator

from hriplan import HriplanError
from hriplan.recent import Recent
from hriplan.robots.assets import resolve_package_uri
from hriplan.robots.bounding import fit_box, fit_capsule
from hriplan.robots.fit_cache import array, array_data, cached_fit, se3, se3_data
from hriplan.robots.spatial import norm

Side = Literal["left", "right"]
SEGMENTS = (
    "middle_pelvis",
    "middle_abdomen",
    "middle_thorax",
    "middle_head",
    "left_upperarm",
    "left_lowerarm",
    "left_hand",
    "right_upperarm",
    "right_lowerarm",
    "right_hand",
    "left_upperleg",
    "left_lowerleg",
    "left_foot",
    "right_upperleg",
    "right_lowerleg",
    "right_foot",
)
REACH_JOINTS = ("shoulder_Z", "shoulder_X", "shoulder_Y", "elbow_Z", "elbow_Y")
POSTURE_JOINTS = {
    "standing": {},
    "seated": {"left_hip_Z": np.pi / 2, "right_hip_Z": np.pi / 2, "left_knee_Z": np.pi / 2, "right_knee_Z": np.pi / 2},
}
DEFAULT_WEIGHT = 75.0
# Where a person holds an object given to or taken from the robot: its centre this far in front
# of the palm centre, along the way they face. Larger than a real grip: the robot's finger
# capsules (r 3.5 cm) and the person's hand capsule (r 5.3 cm) must stay apart, since hriplan
# never lets the robot touch a person.
HELD_OBJECT_OFFSET = 0.19


class BodyReach(BaseModel):
    """Where a hand reaches, relative to the person's body, so that it moves and turns with them
    (a sweep over where a person stands then moves their hand too): `forward` along the way they
    face, `left` to their left (negative: their right), `up` above the floor, in metres."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    forward: float = 0.0
    left: float = 0.0
    up: float = Field(gt=0.0)


def _reach_form(value: object) -> str | None:
    """A reach's form by its shape: a mapping is body-relative, a list a world point."""
    if isinstance(value, (dict, BodyReach)):
        return "body"
    return "world" if isinstance(value, (list, tuple)) else None


Reach = Annotated[
    Annotated[tuple[float, float, float], Tag("world")] | Annotated[BodyReach, Tag("body")],
    Discriminator(
        _reach_form,
        custom_error_type="reach_form",
        custom_error_message="a reach is a world point [x, y, z] or, relative to the body, {forward, left, up}",
    ),
]


class HumanSpec(BaseModel):
    """Where a person is and how they stand; the model faces +x of its base frame at yaw 0."""

    model_config = ConfigDict(extra="forbid")

    name: str = "human"
    posture: Literal["standing", "seated"] = "standing"
    position: tuple[float, float] = (1.0, 0.0)
    yaw: float = np.pi
    height: float | None = Field(default=None, gt=0.5, lt=2.5)
    reach: dict[Side, Reach] = Field(default_factory=dict)
    margin: float = Field(default=0.0, ge=0.0)

    def reach_point(self, side: Side) -> np.ndarray:
        """The world point the `side` hand reaches to: a body-relative reach turned by the
        person's yaw and set at their position, a world point as it is."""
        target = self.reach[side]
        if not isinstance(target, BodyReach):
            return np.asarray(target, dtype=float)
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        x, y = self.position
        return np.array([x + c * target.forward - s * target.left, y + s * target.forward + c * target.left, target.up])


def handing_hand(person: HumanSpec, named: Side | None = None) -> Side:
    """The hand `person` hands or takes with: `named` if given, else the one they reach out if
    they reach out one, else the right. A named hand they do not reach out is a ValueError (the
    object would go to a hanging hand)."""
    if named is None:
        return next(iter(person.reach)) if len(person.reach) == 1 else "right"
    if person.reach and named not in person.reach:
        raise ValueError(
            f"{person.name} hands with the {named} hand but reaches out only the {', '.join(person.reach)} one"
        )
    return named


HAND = "The hand they hand or take with: the one they reach out if they reach out one, else the right."
Person = TypeVar("Person", bound=HumanSpec)


def _with_handing_hand(person: Person) -> Person:
    person.hand = handing_hand(person, person.hand if "hand" in person.model_fields_set else None)
    return person


# The validator of a person model with a `hand` field (a task's, a situation's): its hand as
# `handing_hand` chooses. (Not a base class: the models' fields keep their order, `hand` last.)
hand_they_reach_out = model_validator(mode="after")(_with_handing_hand)


@dataclass(frozen=True)
class HumanCapsule:
    name: str
    joint: int
    radius: float
    length: float
    placement: pin.SE3  # in the segment's joint frame


# Change whenever the way a person's capsules and frames are fitted changes: it keys the disk cache.
FIT_RULES = (
    "a capsule per segment on its visual meshes; hand, head and thorax frames at their box centres; "
    "each segment's mesh hull vertices (to stand the body on the floor), kept as base64 float64"
)


@functools.cache
def _loaded(
    height: float | None,
) -> tuple[pin.Model, tuple[HumanCapsule, ...], dict[str, tuple[int, pin.SE3]], tuple[tuple[int, np.ndarray], ...]]:
    """The body model (kinematics), its capsules and named frames, fitted once per machine
    (fit_cache.py: loading and fitting the meshes takes most of a second)."""
    data = cached_fit("human", (FIT_RULES, height, DEFAULT_WEIGHT), lambda: _fitted(height))
    model = pin.Model()
    model.loadFromString(data["model"])
    capsules = tuple(
        HumanCapsule(c["name"], c["joint"], c["radius"], c["length"], se3(c["placement"])) for c in data["capsules"]
    )
    frames = {name: (joint, se3(placement)) for name, (joint, placement) in data["frames"].items()}
    hulls = tuple((int(joint), array(points, 3)) for joint, points in data["hulls"])
    return model, capsules, frames, hulls


def _fitted(height: float | None) -> dict:
    from scipy.spatial import ConvexHull  # only when fitting (the fit cache serves `constraints` without scipy)

    loader = HumanLoader(height=height, weight=DEFAULT_WEIGHT if height else None)
    model, visual = loader.robot.model, loader.robot.visual_model
    points: dict[str, list[np.ndarray]] = {s: [] for s in SEGMENTS}
    joints: dict[str, int] = {}
    loader_mesh = coal.MeshLoader()
    for geom in visual.geometryObjects:
        segment = model.frames[geom.parentFrame].name
        if segment not in points:
            continue
        mesh = loader_mesh.load(resolve_package_uri(geom.meshPath), np.asarray(geom.meshScale))
        vertices = np.asarray(mesh.vertices())
        points[segment].append(vertices @ geom.placement.rotation.T + geom.placement.translation)
        joints[segment] = geom.parentJoint
    capsules, hulls = [], []
    named: dict[str, tuple[int, pin.SE3]] = {}
    for segment in SEGMENTS:
        cloud = np.vstack(points[segment])
        hulls.append((joints[segment], array_data(cloud[ConvexHull(cloud).vertices])))
        radius, length, placement = fit_capsule(cloud)
        capsules.append(HumanCapsule(segment, joints[segment], radius, length, placement))
        if segment.endswith("hand") or segment in ("middle_head", "middle_thorax"):
            _, centre = fit_box(cloud)
            named[segment] = (joints[segment], centre)
    frames = {"head": "middle_head", "torso": "middle_thorax", "left_hand": "left_hand", "right_hand": "right_hand"}
    return {
        "model": model.saveToString(),
        "capsules": [
            {
                "name": c.name,
                "joint": c.joint,
                "radius": c.radius,
                "length": c.length,
                "placement": se3_data(c.placement),
            }
            for c in capsules
        ],
        "frames": {name: (named[segment][0], se3_data(named[segment][1])) for name, segment in frames.items()},
        "hulls": hulls,
    }


# A seed still this far from the target (m) after this many steps is not converging (it swings
# against the joint limits): the next seed is tried.
_GIVE_UP_AFTER, _GIVE_UP_ERROR = 40, 0.05
# Nor is one still that far whose distance has not fallen below 99 % of its best for this many
# steps: a hanging arm reaching forward swings between two distances, and waiting for step 40
# made two thirds of a moved receiver's posing (44 of 50 kinematics passes).
_STALLED_AFTER, _PROGRESS = 10, 0.99
# The arm postures (REACH_JOINTS) the reach starts from, in order, until one reaches: hanging, bent
# forward, raised; then four drawn once over the joints' ranges (numpy's default_rng(3)), tried only
# when those miss: the first three missed 44 of 400 reachable targets (arm joints drawn within their
# limits, the person anywhere), which were refused as out of reach; with the four, none.
_SEEDS = tuple(
    np.array(seed)
    for seed in (
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [0.8, 0.0, 0.0, 0.8, 0.0],
        [1.4, 0.3, 0.0, 0.3, 0.0],
        [-2.6, -0.06, 2.2, 1.53, -0.02],
        [-0.42, 0.96, -0.82, 1.92, 0.05],
        [-0.68, 1.12, 0.46, 1.54, 2.23],
        [2.87, 0.14, 1.48, 1.82, 0.67],
    )
)
# Solved configurations per spec, oldest forgotten first.
_CONFIGURATIONS: Recent[str, np.ndarray] = Recent(256)


class Human:
    """A person in the scene: pose it with a `HumanSpec`, read capsules and frames in the world."""

    FRAMES = ("head", "torso", "left_hand", "right_hand", "base")

    def __init__(self, spec: HumanSpec | None = None) -> None:
        self.spec = spec or HumanSpec()
        self.model, self.capsules, self._frames, self._hulls = _loaded(self.spec.height)
        self.data = self.model.createData()
        self.q = pin.neutral(self.model)
        self.pose(self.spec)

    def pose(self, spec: HumanSpec) -> None:
        """Re-pose the person (posture, base pose, reaching arms) without reloading the model.
        Configurations are remembered per spec: posing solves the arms' IK (~20 ms), and every
        stage of a re-plan poses the same people again. A spec that cannot be posed (a reach out
        of range) leaves the person as they were."""
        if spec.height != self.spec.height:
            raise HriplanError("a person's height is fixed when the Human is created")
        key = spec.model_dump_json()  # the height in it fixes the body model
        q = _CONFIGURATIONS.get(key)
        if q is None:
            posed, self.spec = self.spec, spec
            try:
                q = self._solved(spec)
            except HriplanError:  # solving moved the kinematics: back where the person stands
                pin.forwardKinematics(self.model, self.data, self.q)
                raise
            finally:
                self.spec = posed
            _CONFIGURATIONS.put(key, q)
        self.spec, self.q = spec, q.copy()
        pin.forwardKinematics(self.model, self.data, self.q)

    def _solved(self, spec: HumanSpec) -> np.ndarray:
        """The configuration for `spec`: posture, base placement, then each reaching arm's IK."""
        q = pin.neutral(self.model)
        for joint, value in POSTURE_JOINTS[spec.posture].items():
            q[self._iq(joint)] = value
        # The loader fixes the root joint's rotation (its y-up mesh frame to z-up): conjugate.
        root = self.model.jointPlacements[1]
        q[:7] = pin.SE3ToXYZQUAT(root.inverse() * self._base_placement(q) * root)
        for side in spec.reach:
            q = self._reach(q, side, spec.reach_point(side))
        return q

    def _iq(self, joint: str) -> int:
        return self.model.joints[self.model.getJointId(joint)].idx_q

    def _base_placement(self, q: np.ndarray) -> pin.SE3:
        """World placement of the body: yaw about z, the lowest point of its meshes (the soles, not
        the capsules around them, which reach below them) on the floor."""
        q = q.copy()
        q[:7] = pin.SE3ToXYZQUAT(pin.SE3.Identity())
        pin.forwardKinematics(self.model, self.data, q)
        lowest = min(
            float(np.min(hull @ self.data.oMi[joint].rotation[2] + self.data.oMi[joint].translation[2]))
            for joint, hull in self._hulls
        )
        x, y = self.spec.position
        return pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, self.spec.yaw), np.array([x, y, -lowest]))

    def _capsule_world(self, capsule: HumanCapsule) -> pin.SE3:
        return self.data.oMi[capsule.joint] * capsule.placement

    def _reach(self, q: np.ndarray, side: Side, target: np.ndarray) -> np.ndarray:
        """Damped least squares on the shoulder and elbow so the palm centre reaches `target`: the
        first of a few seed postures that reaches it, else the closest; a seed that stops closing in
        is left early (`_STALLED_AFTER`). What does not change
        between steps (indices, limits, the palm's offset as an action, the damping) is made once
        and each step's norm once: Python, not pinocchio (~4 of ~70 us), made a step's cost, and a
        re-plan poses its moved person anew. The arithmetic is the earlier loop's, to the bit."""
        joint, offset = self._frames[f"{side}_hand"]
        ids = [self.model.getJointId(f"{side}_{j}") for j in REACH_JOINTS]
        idx = np.array([self.model.joints[i].idx_q for i in ids])
        vidx = np.array([self.model.joints[i].idx_v for i in ids])
        lower, upper = self.model.lowerPositionLimit[idx], self.model.upperPositionLimit[idx]
        to_palm = pin.SE3(np.eye(3), offset.translation).toActionMatrixInverse()
        damping = 1e-4 * np.eye(3)
        best_q, best_err = q, np.inf
        for seed in _SEEDS:
            qs = q.copy()
            qs[idx] = np.clip(seed, lower, upper)
            closest, stalled = math.inf, 0
            for iteration in range(200):
                pin.forwardKinematics(self.model, self.data, qs)
                err = target - (self.data.oMi[joint] * offset).translation
                distance = norm(err)
                if distance < 1e-4:
                    break
                closest, stalled = (distance, 0) if distance < _PROGRESS * closest else (closest, stalled + 1)
                if distance > _GIVE_UP_ERROR and (iteration >= _GIVE_UP_AFTER or stalled >= _STALLED_AFTER):
                    break
                local = to_palm @ pin.computeJointJacobian(self.model, self.data, qs, joint)
                lin = (self.data.oMi[joint].rotation @ local[:3])[:, vidx]
                step = lin.T @ np.linalg.solve(lin @ lin.T + damping, err)
                qs[idx] = np.minimum(np.maximum(qs[idx] + step, lower), upper)  # np.clip's
            pin.forwardKinematics(self.model, self.data, qs)
            err = np.linalg.norm(target - (self.data.oMi[joint] * offset).translation)
            if err < best_err:
                best_q, best_err = qs, err
            if best_err < 1e-4:  # reached: the next seeds would only find another arm posture for it
                break
        if best_err > 0.01:
            raise HriplanError(
                f"{self.spec.name}'s {side} hand cannot reach {target.round(3).tolist()} (closest {best_err:.2f} m away)"
            )
        return best_q

    # -- world geometry -------------------------------------------------------------------
    def capsule_placements(self) -> list[pin.SE3]:
        """World placement of every capsule, in `capsules` order."""
        return [self._capsule_world(c) for c in self.capsules]

    def frame(self, name: str) -> pin.SE3:
        """World pose of a named frame: head, torso, left_hand, right_hand (palm centre), base.

        Every frame is oriented like the person's base (z up, x the way the person faces), so
        that "towards the person" and "from the person's front" mean the same for every part."""
        x, y = self.spec.position
        base = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, self.spec.yaw), np.array([x, y, 0.0]))
        if name == "base":
            return base
        if name not in self._frames:
            raise HriplanError(f"a human has no frame {name!r}; frames: {', '.join(self.FRAMES)}")
        joint, offset = self._frames[name]
        return pin.SE3(base.rotation, (self.data.oMi[joint] * offset).translation)


@functools.cache
def _display_model(height: float | None) -> pin.GeometryModel:
    """The loader's visual meshes: the ones the capsules were fitted to."""
    return HumanLoader(height=height, weight=DEFAULT_WEIGHT if height else None).robot.visual_model


def display_meshes(human: Human) -> list[tuple[pin.GeometryObject, pin.SE3]]:
    """Every display mesh of a posed person with its world placement (for viewers)."""
    model = _display_model(human.spec.height)
    data, geometry_data = human.model.createData(), model.createData()
    pin.forwardKinematics(human.model, data, human.q)
    pin.updateGeometryPlacements(human.model, data, model, geometry_data)
    return [(geometry, pin.SE3(placement)) for geometry, placement in zip(model.geometryObjects, geometry_data.oMg)]


_POSED: dict[float | None, Human] = {}  # one Human per body height, posed for `person_frame`
_POSED_LOCK = threading.Lock()


def person_frame(spec: HumanSpec, name: str) -> pin.SE3:
    """`Human.frame(name)` of a person posed as `spec`, on one Human kept per body height: making a
    Human costs about a millisecond (its pinocchio data), posing it for a spec seen before some
    microseconds, and every derivation asks where a person's hand is."""
    with _POSED_LOCK:
        human = _POSED.get(spec.height)
        if human is None:
            human = _POSED[spec.height] = Human(spec)
        else:
            human.pose(spec)
        return human.frame(name)
