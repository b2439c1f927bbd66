"""The robot object the planner calls: kinematics of the arm joints with the hands' fingers fixed.

`load_robot("madar")` builds the full URDF model (every joint, for display and export) and a
planning model in which wheels and finger joints are locked at the chosen hand postures, so
forward kinematics and Jacobians cost only the 12 arm joints.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import coal
import numpy as np
import pinocchio as pin

from hriplan import HriplanError
from hriplan.robots.descriptions.description import RobotDescription, hand_model
from hriplan.robots.descriptions.registry import DESCRIPTIONS, description_of
from hriplan.robots.spatial import Pose

JointValues = Mapping[str, float] | Sequence[float] | np.ndarray


@dataclass(frozen=True)
class RobotSpec:
    """What distinguishes one loaded robot from another (and keys caches built for it)."""

    name: str
    hand_postures: tuple[tuple[str, str], ...] = ()
    base_pose: Pose = field(default_factory=Pose)
    source: str = ""  # the robot file it was read from ("" built in): a name may be registered anew


def _groups(description: RobotDescription, model_order: list[str]) -> dict[str, list[str]]:
    """Joint groups: each arm's, and the whole robot's in the model's order (MADAR: left, then
    right), so that its vector is also the full planning configuration."""
    groups = {arm.group: list(arm.joints) for arm in description.arms.values()}
    return groups | {description.whole_group: model_order}


def _mount(description: RobotDescription) -> pin.SE3:
    """Where the description stands the robot in the world."""
    xyz, rpy = description.base_pose
    return Pose(xyz=xyz, rpy=rpy).se3()


def _add_alias_frames(model: pin.Model, aliases: Mapping[str, str], robot: str) -> None:
    """A frame per link alias, on its link (same joint and placement), so every frame lookup
    (constraint target links, IK, tool frames) takes the alias like the link."""
    for alias, link in aliases.items():
        if model.existFrame(alias):
            raise HriplanError(f"robot {robot!r}: link alias {alias!r} is already a frame of its URDF")
        if not model.existFrame(link):
            raise HriplanError(f"robot {robot!r}: link alias {alias!r} names an unknown link {link!r}")
        frame = model.frames[model.getFrameId(link)]
        model.addFrame(
            pin.Frame(alias, frame.parentJoint, model.getFrameId(link), frame.placement, pin.FrameType.OP_FRAME)
        )


def _place_base(model: pin.Model, base: pin.SE3) -> None:
    for j in range(1, model.njoints):
        if model.parents[j] == 0:
            model.jointPlacements[j] = base * model.jointPlacements[j]
    for frame in model.frames:
        if frame.parentJoint == 0 and frame.name != "universe":
            frame.placement = base * frame.placement


def urdf_geometry(model: pin.Model, urdf: str, kind: pin.GeometryType) -> pin.GeometryModel:
    """A URDF's collision or visual shapes on `model`, each mesh file read once: MADAR's arms share
    their seven meshes (loading them once halves the 40-50 ms its collision meshes took)."""
    try:
        return pin.buildGeomFromUrdfString(model, urdf, kind, mesh_loader=coal.CachedMeshLoader())
    except ValueError as exc:  # coal's loader: a mesh file there but unreadable (an empty STL)
        lines = [line.removeprefix("message: ") for line in str(exc).splitlines() if line.strip()]
        reason = next((line for line in lines if line.startswith("Could not load")), lines[-1] if lines else "")
        detail = lines[lines.index(reason) + 1] if reason in lines[:-1] else ""
        raise HriplanError(f"a mesh of the URDF does not load: {reason}" + (f" ({detail})" if detail else "")) from None


@functools.cache
def _full_body(spec: RobotSpec) -> tuple[pin.Model, pin.GeometryModel]:
    """The full URDF model, placed, and its collision meshes: the same whatever the hands' postures
    (`spec` has none), so the robots of one task (a hand closed, then opened to release) load the
    meshes once (about 50 ms for MADAR). Shared between those robots: never changed after this."""
    description = description_of(spec.name)
    urdf = description.urdf()
    model = pin.buildModelFromXML(urdf)
    _place_base(model, spec.base_pose.se3() * _mount(description))
    _add_alias_frames(model, description.link_aliases, spec.name)
    return model, urdf_geometry(model, urdf, pin.COLLISION)


def arms_of(name: str) -> dict[str, tuple[str, str]]:
    """Arm name -> (joint prefix, tool frame) of a robot description."""
    return {arm: (d.prefix, d.tool_frame) for arm, d in description_of(name).arms.items()}


class Robot:
    """Pinocchio model of one robot, with named joint groups, limits, poses and Jacobians."""

    def __init__(self, spec: RobotSpec) -> None:
        self.spec = spec
        self.name = spec.name
        self.description = description_of(spec.name)
        self.urdf = self.description.urdf()
        self.full_model, self.full_collision = _full_body(replace(spec, hand_postures=()))
        self.hand_postures = dict(spec.hand_postures)
        self._q_locked = self.full_configuration({})
        arm_joints = {j for arm in self.description.arms.values() for j in arm.joints}
        self._locked = [j for j in range(1, self.full_model.njoints) if self.full_model.names[j] not in arm_joints]
        self.model, self.collision_meshes = pin.buildReducedModel(
            self.full_model, self.full_collision, self._locked, self._q_locked
        )
        self.data = self.model.createData()
        self.joint_names = [self.model.names[j] for j in range(1, self.model.njoints)]
        self.groups = _groups(self.description, self.joint_names)
        self.arms = arms_of(spec.name)
        self.link_aliases = self.description.link_aliases
        self._index = {
            g: np.array([self.model.joints[self.model.getJointId(j)].idx_q for j in names])
            for g, names in self.groups.items()
        }
        self._vindex = {
            g: np.array([self.model.joints[self.model.getJointId(j)].idx_v for j in names])
            for g, names in self.groups.items()
        }
        self.q_neutral = pin.neutral(self.model)
        # Read once: a pinocchio lookup costs about a microsecond from Python, and IK and the
        # retreat ask these thousands of times a re-plan. The model never changes after this.
        self._slot_of = {name: self.model.joints[self.model.getJointId(name)].idx_q for name in self.joint_names}
        self._frame_ids: dict[str, int] = {}

    @functools.cached_property
    def full_visual(self) -> pin.GeometryModel:
        """The visual meshes of the full model, loaded when first drawn or fitted (about a second:
        a process that only derives or plans from cached parts never pays it)."""
        return urdf_geometry(self.full_model, self.urdf, pin.VISUAL)

    @functools.cached_property
    def visual(self) -> pin.GeometryModel:
        """The visual meshes on the planning model (fingers at their postures)."""
        return pin.buildReducedModel(self.full_model, self.full_visual, self._locked, self._q_locked)[1]

    @property
    def default_group(self) -> str:
        return self.description.whole_group

    @functools.cached_property
    def model_key(self) -> str:
        """A digest of the planning model as built: its joints, their placements (the base pose
        in them) and limits, and every frame's joint and placement (where locked joints and the
        base put the fixed links). Caches of what is computed on this model (fitted parts,
        collision matrix, clearance tables) are keyed by it: keyed by the URDF and hand postures
        alone, a robot file whose arms or base changed was served parts fitted for the old model
        (TIAGo's little finger parts on joints that no longer moved; a UR5's base part at the
        origin on a UR5 placed at x = 1 m)."""
        model = self.model
        digest = hashlib.sha256(repr([model.names[j] for j in range(model.njoints)]).encode())
        for placement in [*model.jointPlacements, *(f.placement for f in model.frames)]:
            digest.update(np.ascontiguousarray(placement.homogeneous).tobytes())
        digest.update(np.array([f.parentJoint for f in model.frames]).tobytes())
        for limit in (model.lowerPositionLimit, model.upperPositionLimit):
            digest.update(np.ascontiguousarray(limit).tobytes())
        return digest.hexdigest()[:16]

    @functools.cached_property
    def finger_values(self) -> tuple[tuple[str, float], ...]:
        """Every finger joint's value at its hand's posture (what caches of fitted shapes are keyed
        by, with the posture names: a posture whose values change is fitted again)."""
        values = []
        for side, posture in self.hand_postures.items():
            arm = self.description.arms[side]
            hand = hand_model(arm.hand)
            values += [(hand.joint_name(arm.prefix, j), v) for j, v in hand.joint_values(posture).items()]
        return tuple(sorted(values))

    def full_configuration(self, arm_values: Mapping[str, float]) -> np.ndarray:
        """Configuration of the full URDF model: fingers at their postures, arms as given."""
        q = pin.neutral(self.full_model)
        for name, value in [*self.finger_values, *arm_values.items()]:
            q[self.full_model.joints[self.full_model.getJointId(name)].idx_q] = value
        return q

    # -- joint values -----------------------------------------------------------------------
    def group_joints(self, group: str | None = None) -> list[str]:
        return list(self.groups[self._group(group)])

    def _group(self, group: str | None) -> str:
        group = group or self.default_group
        if group not in self.groups:
            raise HriplanError(f"robot {self.name!r} has no joint group {group!r}; groups: {', '.join(self.groups)}")
        return group

    def moved_joints(self, group: str | None = None) -> frozenset[int]:
        """Model joint ids that move when the group moves: its joints and every joint below them."""
        model = self.model
        planned = {model.getJointId(j) for j in self.group_joints(group)}
        moved = set()
        for joint in range(1, model.njoints):
            ancestor = joint
            while ancestor > 0 and ancestor not in planned:
                ancestor = model.parents[ancestor]
            if ancestor > 0:
                moved.add(joint)
        return frozenset(moved)

    def group_indices(self, group: str | None = None) -> np.ndarray:
        """Indices of the group's joints in the planning model's configuration vector."""
        return self._index[self._group(group)]

    def limits(self, group: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        idx = self.group_indices(group)
        return self.model.lowerPositionLimit[idx].copy(), self.model.upperPositionLimit[idx].copy()

    def velocity_indices(self, group: str | None = None) -> np.ndarray:
        """Indices of the group's joints in the planning model's velocity vector."""
        return self._vindex[self._group(group)]

    def velocity_limit(self, group: str | None = None) -> np.ndarray:
        return self.model.velocityLimit[self.velocity_indices(group)].copy()

    def configuration(
        self, values: JointValues, group: str | None = None, base: np.ndarray | None = None
    ) -> np.ndarray:
        """Full planning configuration from a dict of joint values or a vector in group order.

        Joints not named keep their value in `base` (default: zeros)."""
        q = (self.q_neutral if base is None else base).copy()
        if isinstance(values, Mapping):
            for name, value in values.items():
                if name not in self._slot_of:
                    raise HriplanError(f"robot {self.name!r} has no arm joint {name!r}")
                q[self._slot_of[name]] = float(value)
        else:
            vec = np.asarray(values, dtype=float).ravel()
            idx = self.group_indices(group)
            if vec.shape[0] != idx.shape[0]:
                raise HriplanError(
                    f"group {self._group(group)!r} has {idx.shape[0]} joints, got a vector of {vec.shape[0]} values"
                )
            q[idx] = vec
        if not np.isfinite(q).all():
            raise HriplanError(f"joint values must be finite numbers, got {q.tolist()}")
        return q

    def group_values(self, q: np.ndarray, group: str | None = None) -> np.ndarray:
        return np.asarray(q)[self.group_indices(group)].copy()

    def _full(self, values: JointValues, group: str | None) -> np.ndarray:
        """Fast path for a full configuration vector (what the planner passes millions of times)."""
        if isinstance(values, np.ndarray) and values.shape == (self.model.nq,) and group in (None, self.default_group):
            return values
        return self.configuration(values, group)

    # -- frames -----------------------------------------------------------------------------
    def frame_id(self, name: str) -> int:
        fid = self._frame_ids.get(name)
        if fid is None:
            if not self.model.existFrame(name):
                raise HriplanError(f"robot {self.name!r} has no frame {name!r}")
            fid = self._frame_ids[name] = self.model.getFrameId(name)
        return fid

    def link_name(self, name: str) -> str:
        """The link `name` stands for: itself, or the link it is another description's alias of."""
        return self.link_aliases.get(name, name)

    def frame_pose(self, name: str, values: JointValues, group: str | None = None) -> np.ndarray:
        """4x4 pose of frame `name` in the world for the given joint values."""
        q = self._full(values, group)
        fid = self.frame_id(name)
        pin.forwardKinematics(self.model, self.data, q)
        return pin.updateFramePlacement(self.model, self.data, fid).homogeneous

    def frame_jacobian(
        self,
        name: str,
        values: JointValues,
        group: str | None = None,
        reference: pin.ReferenceFrame = pin.LOCAL_WORLD_ALIGNED,
    ) -> np.ndarray:
        """6 x n Jacobian (linear; angular) of frame `name`, columns in group-joint order."""
        q = self._full(values, group)
        fid = self.frame_id(name)
        jac = pin.computeFrameJacobian(self.model, self.data, q, fid, reference)
        return jac[:, self._vindex[self._group(group)]]

    def tool_frame(self, arm: str) -> str:
        return self._arm(arm)[1]

    def arm_group(self, arm: str) -> str:
        self._arm(arm)
        return self.description.arms[arm].group

    def _arm(self, arm: str) -> tuple[str, str]:
        if arm not in self.arms:
            raise HriplanError(f"robot {self.name!r} has no arm {arm!r}; arms: {', '.join(self.arms)}")
        return self.arms[arm]


ROBOT_NAMES = tuple(DESCRIPTIONS)


def load_robot(
    name: str,
    hand_postures: Mapping[str, str] | None = None,
    base_pose: Pose | None = None,
) -> Robot:
    """Load `madar` or `ur5`. A hand has its model's first posture unless one is given (the Allegro's: open).

    Robots are cached per (name, hand postures, base pose): loading meshes takes about a second,
    and callers share the instance (so share a robot between threads only with care)."""
    description = description_of(name)
    hands = {side: hand_model(description.arms[side].hand) for side in description.hands}
    postures = {side: hand.postures[0] for side, hand in hands.items()}
    for side, posture in (hand_postures or {}).items():
        if side not in postures:
            raise HriplanError(f"robot {name!r} has no hand {side!r}")
        if posture not in hands[side].postures:
            raise HriplanError(f"unknown hand posture {posture!r}; choose one of {', '.join(hands[side].postures)}")
        postures[side] = posture
    return _cached_robot(
        RobotSpec(name, tuple(sorted(postures.items())), base_pose or Pose(), description.source or "")
    )


@functools.cache
def _cached_robot(spec: RobotSpec) -> Robot:
    return Robot(spec)
