"""`hriplan robot check` and `hriplan robot init`: what a robot file gives, measured (IK success on
random reachable poses, the SRDF's disabled pairs against the sampled collision matrix), and a
starting robot file written from a URDF and, where there is one, its SRDF."""

from __future__ import annotations

import collections
import math
import os
import re
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin
import yaml

from hriplan import HriplanError
from hriplan.files import read_text, write_atomically
from hriplan.robots.acm import MESH, load_acm
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.description import RobotDescription, hand_model
from hriplan.robots.descriptions.registry import DESCRIPTIONS, load_robot_file
from hriplan.robots.ik import ANALYTIC_IK, fit_analytic, solve_ik
from hriplan.robots.info import describe
from hriplan.robots.model import Robot, load_robot
from hriplan.robots.robot_file import package_search_path, resolve_file
from hriplan.robots.robot_geometry import NO_COLLISION_SHAPES, robot_parts
from hriplan.robots.scene import Scene
from hriplan.robots.srdf import Srdf, read_srdf
from hriplan.robots.urdf_tree import MOVABLE, UrdfTree

CHECK_POSES = 100


def ik_rate(robot: Robot, arm: str, poses: int = CHECK_POSES) -> tuple[int, float]:
    """(solved, median ms) over `poses` random reachable tool poses (FK of random configurations)."""
    group = robot.arm_group(arm)
    rng = np.random.default_rng(0)
    lower, upper = robot.limits(group)
    targets = [robot.frame_pose(robot.tool_frame(arm), rng.uniform(lower, upper), group) for _ in range(poses)]
    solve_ik(robot, arm, targets[0])  # an analytic solver is placed once, not timed
    solved, times = 0, []
    for target in targets:
        start = time.perf_counter()
        solved += solve_ik(robot, arm, target).success
        times.append((time.perf_counter() - start) * 1e3)
    return solved, float(np.median(times))


def _srdf_pairs(robot: Robot, srdf: Srdf) -> str:
    """The SRDF's disabled pairs against the sampled collision matrix: agreeing, or checked here."""
    parts = robot_parts(robot)
    acm = load_acm(robot, parts)
    by_link = collections.defaultdict(list)
    for part in parts:
        by_link[part.link].append(part.name)
    agree, meshes, checked, bare = 0, 0, [], 0
    for a, b, _reason in srdf.disabled:
        pairs = [(p, r) for p in by_link[a] for r in by_link[b] if p != r]
        if not pairs:
            bare += 1
            continue
        reasons = {acm.get(f"{p}|{r}", acm.get(f"{r}|{p}")) for p, r in pairs}
        if None in reasons:
            checked.append(f"{a}-{b}")
        elif MESH in reasons:
            meshes += 1
        else:
            agree += 1
    touched = f" ({', '.join(checked)})" if checked else ""
    return (
        f"SRDF disabled pairs: {len(srdf.disabled)}: {agree} not checked here either (adjacent, never or always touching "
        f"in sampling), {meshes} checked on meshes, {len(checked)} checked on parts: they touched in sampling"
        f"{touched}, {bare} without collision geometry"
    )


def check_report(path: str | Path) -> str:
    """Everything `hriplan robot check` prints for a robot file (or one HriplanError line)."""
    description = load_robot_file(path)
    robot = load_robot(description.name)
    srdf = description.srdf
    lines = [f"robot {description.name} from {Path(path).resolve()}"]
    if srdf is None:
        lines.append("SRDF: none (arms by base and tip links)")
    else:
        lines.append("SRDF groups: " + ", ".join(f"{g} ({len(j)} joints)" for g, j in srdf.groups.items()))
        lines += srdf.ignored
    lines.append(describe(robot))
    for arm, a in description.arms.items():
        # Which tool axis must point up for a held cup to stand upright: TALOS's right and left
        # wrists are not mirror images, so one tool frame needs turning where the other does not.
        held = (
            f"hand none, a held object upright when tool {a.object_axis} points up"
            if a.hand is None
            else f"hand {hand_model(a.hand).label}, a side-grasped cup upright when tool {a.hand_axes[1]} points up"
        )
        lines.append(f"arm {arm}: joints {', '.join(a.joints)} on {a.base_link}; tool frame {a.tool_frame}; {held}")
        solved, median = ik_rate(robot, arm)
        lines.append(
            f"arm {arm}: IK {a.ik}: {solved} of {CHECK_POSES} random reachable poses solved, median {median:.2f} ms"
        )
    lines.append("postures: " + (", ".join(description.postures) or "none"))
    lines += _colliding_postures(CollisionChecker(robot, Scene()), description.postures)
    if srdf is not None:
        lines.append(_srdf_pairs(robot, srdf))
    return "\n".join(lines)


def _colliding_postures(checker: CollisionChecker, postures: dict[str, dict[str, float]]) -> list[str]:
    """A line per posture in which the robot collides with itself (`checker`: the robot alone):
    a task cannot start there."""
    robot = checker.robot
    lines = []
    for name, values in postures.items():
        contacts = checker.contacts(robot.configuration(values))
        if contacts:
            pairs = ", ".join(f"{c.a} - {c.b}" for c in contacts[:3]) + (", ..." if len(contacts) > 3 else "")
            lines.append(f"posture {name}: in self-collision ({pairs}): a task cannot start there")
    return lines


# The end of every file `robot init` writes: planning near people needs the robot's ISO/TS 15066
# stopping data, which only a measurement of the deployed robot gives.
STOPPING_TODO = (
    "# Planning near people needs ISO/TS 15066 stopping data, measured on the deployed robot:\n"
    "# stopping: {reaction_time: S, stopping_time: S, position_uncertainty: M, moving_mass: KG}\n"
)
# Random postures `robot init` tries when none of its named candidates is free of self-collision.
FREE_SEARCH_SAMPLES = 2000


def _nearest_free(
    checker: CollisionChecker, centre: dict[str, float], ranges: dict[str, tuple[float, float]]
) -> dict[str, float] | None:
    """The posture nearest `centre` (each joint's offset as a share of its range) the robot does
    not touch itself in, of FREE_SEARCH_SAMPLES random ones (seeded: init writes the same file
    every time); None if all touch. TIAGo's arm at zero and mid-range lies on its torso column,
    a Panda's without its SRDF folds its hand onto its forearm: a start a task can use beats one
    said to be in self-collision."""
    names = list(ranges)
    lower, upper = (np.array([ranges[j][k] for j in names]) for k in (0, 1))
    span = np.maximum(upper - lower, 1e-9)
    # Rounded as a file is written, then kept within range (a limit may have more decimals).
    samples = np.clip(
        np.round(np.random.default_rng(0).uniform(lower, upper, (FREE_SEARCH_SAMPLES, len(names))), 4), lower, upper
    )
    offsets = np.abs((samples - np.array([centre[j] for j in names])) / span).max(axis=1)
    for k in np.argsort(offsets, kind="stable"):
        posture = dict(zip(names, samples[k].tolist()))
        if not checker.in_collision(checker.robot.configuration(posture)):
            return posture
    return None


def _identifier(name: str) -> str:
    name = re.sub(r"\W", "_", name or "robot")
    return name if re.match(r"[A-Za-z]", name) else f"robot_{name}"


def _arms_from_srdf(tree: UrdfTree, srdf: Srdf) -> dict[str, dict]:
    """An arm per SRDF end effector: its parent group (or its own group when that is the arm,
    as example-robot-data's Panda has it), the tool frame its parent link."""
    arms = {}
    for end in srdf.end_effectors:
        group = end.parent_group or end.group
        joints = [j for j in tree.movable(srdf.groups.get(group, [])) if tree.joints[j].mimic is None]
        to_tool = {j.name for j in tree.ancestors(end.parent_link)}
        if joints and not set(joints) <= to_tool:
            # The group holds joints off the tool's chain (Bravo 7's fingers in its `arm` group):
            # the arm is the chain from the group's first link to the tool.
            arms[group] = {"base": tree.joints[joints[0]].parent, "tip": end.parent_link}
        else:
            arms[group] = {"group": group, "tool": end.parent_link}
    return arms


def _chains_not_taken(tree: UrdfTree, srdf: Srdf, arms: dict[str, dict]) -> list[str]:
    """A line naming the SRDF's serial groups on no arm init took (nor below one: its hand), or none.
    An SRDF's end effectors may be a humanoid's feet (TALOS's r_foot, l_foot on its legs) and its
    arms plain groups; which chain is an arm is the user's word, so init names the candidates. A
    chain sharing joints with an arm is still one (Centauro's left arm turns with the torso joint
    of the arm init took: the right one)."""
    taken = [set(_arm_joints(tree, srdf, arm)) for arm in arms.values()]
    found = []
    for group, joints in srdf.groups.items():
        moving = _driven([tree.joints[j] for j in tree.movable(joints)])
        tip = max((tree.joints[j].child for j in joints), key=lambda link: len(tree.ancestors(link)), default=None)
        above = {j.name for j in tree.ancestors(tip)} if tip is not None else set()
        on_arm = any(set(moving) <= arm or arm <= above for arm in taken)  # part of an arm, or its hand
        if moving and set(joints) <= above and not on_arm:
            found.append(f"{group} ({len(moving)} joints, to {tip})")
    if not found:
        return []
    return [
        "SRDF groups not taken as arms: " + ", ".join(found) + "; one is an arm as `NAME: {group: GROUP}` under arms"
    ]


def _arm_joints(tree: UrdfTree, srdf: Srdf, arm: dict) -> list[str]:
    """The driven joints of an arm init writes (by its SRDF group, or its base and tip links)."""
    joints = srdf.groups[arm["group"]] if "group" in arm else tree.chain(arm["base"], arm["tip"], "arm")
    return _driven([tree.joints[j] for j in tree.movable(joints)])


def _arm_from_urdf(tree: UrdfTree, shapeless: set[str]) -> dict[str, dict]:
    """The longest chain of moving joints from the root, by its base and tip links; where it ends
    in a hand (fingers branching off one link), the arm ends at that link (`_hand_root`), its tool
    the hand's own frame if the URDF has one (`_tool_frame`; `shapeless`: links without shapes)."""
    best: list[str] = []
    tip = tree.root
    for link in tree.links:
        moving = _driven(tree.ancestors(link))
        if len(moving) >= len(best):  # the last such link in the file: a flange or tool frame
            best, tip = moving, link
    if not best:
        raise HriplanError("the URDF has no moving joints")
    hand = _hand_root(tree, tip)
    tip = hand or tip
    arm = {"base": tree.joints[_driven(tree.ancestors(tip))[-1]].parent, "tip": tip}
    frame = _tool_frame(tree, shapeless, hand) if hand else None
    return {"arm": arm | ({"tool": frame} if frame else {})}


def _tool_frame(tree: UrdfTree, shapeless: set[str], hand: str) -> str | None:
    """The one link fixed to `hand` with no shape and nothing below it: the frame a URDF marks
    its grasp point with (TIAGo's hand_grasping_frame 13 cm out of the palm, a Panda's
    panda_hand_tcp between the fingertips). A held object sits at the tool frame: at the hand's
    root it was inside the wrist. None if there is no such link or more than one."""
    parents = {j.parent for j in tree.joints.values()}
    frames = [
        j.child
        for j in tree.joints.values()
        if j.parent == hand and j.type == "fixed" and j.child in shapeless and j.child not in parents
    ]
    return frames[0] if len(frames) == 1 else None


def _driven(joints: list) -> list[str]:
    """The moving joints among `joints` that no other joint drives (mimic joints follow one)."""
    return [j.name for j in joints if j.type in MOVABLE and j.mimic is None]


def _hand_root(tree: UrdfTree, tip: str) -> str | None:
    """The link the chain to `tip` enters a hand at: the one nearest the tip from which two or
    more branches move (fingers, mimic ones too), with at least as many driven joints above it as
    below it on the chain. Without this, a URDF alone made the longest chain run into a finger:
    TIAGo's "arm" was 15 joints ending at its little finger's tip, a Panda's ended in a finger.
    The balance rule keeps an arm whole where the branching is a torso with a head on it."""
    chain = tree.ancestors(tip)  # nearest the tip first
    for k, joint in enumerate(chain):
        below, above = _driven(chain[: k + 1]), _driven(chain[k + 1 :])
        moving_branches = sum(
            1 for child in tree.joints.values() if child.parent == joint.parent and _moves(tree, child)
        )
        if moving_branches >= 2 and above and len(above) >= len(below):
            return joint.parent
    return None


def _moves(tree: UrdfTree, joint) -> bool:
    """Whether `joint` or any joint below it moves."""
    if joint.type in MOVABLE:
        return True
    return any(_moves(tree, child) for child in tree.joints.values() if child.parent == joint.child)


def _closed_at_lower(text: str, tree: UrdfTree, gripper: list[str], lower: float, upper: float) -> bool:
    """Whether a gripper closes towards its joints' lower limit: its fingers' end links (those no
    finger joint hangs from) are nearer each other there. A Panda's fingers touch at 0 of [0,
    0.04]; TIAGo Pro's fingertips are 3 cm apart at 0.8 of [0, 0.8] and 10 cm at 0. One finger
    gives no distance: its lower limit is taken as closed."""
    ends = [
        tree.joints[j].child for j in gripper if not any(tree.joints[k].parent == tree.joints[j].child for k in gripper)
    ]
    if len(ends) < 2:
        return True
    model = pin.buildModelFromXML(text)
    data = model.createData()
    follows = {
        el.get("name"): (float(m.get("multiplier", 1.0)), float(m.get("offset", 0.0)))
        for el in ET.fromstring(text).findall("joint")
        if (m := el.find("mimic")) is not None
    }

    def spread(value: float) -> float:
        q = pin.neutral(model)
        for j in gripper:
            multiplier, offset = follows.get(j, (1.0, 0.0))
            q[model.joints[model.getJointId(j)].idx_q] = multiplier * value + offset
        pin.framesForwardKinematics(model, data, q)
        points = [data.oMf[model.getFrameId(link)].translation for link in ends]
        return sum(float(np.linalg.norm(a - b)) for k, a in enumerate(points) for b in points[k + 1 :])

    return spread(lower) <= spread(upper)


def _hand(
    text: str, tree: UrdfTree, limits: dict[str, tuple[float, float]], tool: str, arm_joints: set[str]
) -> dict | str:
    """A parallel gripper from the moving joints below the arm's tool: the driven ones share their
    limits, and the fingers that mimic them are listed too, whatever their own limits (TIAGo Pro's
    fingertips mirror its finger joint: limits [-0.8, 0], multiplier -1)."""
    last = next(j for j in tree.ancestors(tool) if j.type in MOVABLE)
    below, stack = [], [last.child]
    while stack:
        link = stack.pop()
        for joint in tree.joints.values():
            if joint.parent == link:
                stack.append(joint.child)
                if joint.type in MOVABLE and joint.name not in arm_joints:
                    below.append(joint.name)
    driven = [j for j in below if tree.joints[j].mimic is None]
    if not driven or len({limits.get(j) for j in driven}) != 1:
        return "none"
    lower, upper = limits[driven[0]]
    gripper = driven + [j for j in below if tree.joints[j].mimic in driven]
    if not _closed_at_lower(text, tree, gripper, lower, upper):
        lower, upper = upper, lower
    return {"gripper": gripper, "open": upper, "closed": lower}


def _ik_kind(text: str, base: str, tool: str, joints: list[str]) -> str:
    """The first analytic UR solver the arm fits, else numeric."""
    model = pin.buildModelFromXML(text)
    data = model.createData()
    if len(joints) != 6 or any(model.joints[model.getJointId(j)].nq != 1 for j in joints):
        return "numeric"

    def relative_tool(values: np.ndarray) -> np.ndarray:
        q = pin.neutral(model)
        for name, value in zip(joints, values):
            q[model.joints[model.getJointId(name)].idx_q] = value
        pin.framesForwardKinematics(model, data, q)
        return (data.oMf[model.getFrameId(base)].inverse() * data.oMf[model.getFrameId(tool)]).homogeneous

    for kind in ANALYTIC_IK:
        try:
            fit_analytic(kind, relative_tool, 6)
            return kind
        except HriplanError:
            continue
    return "numeric"


def _reference(path: Path, output: Path) -> str:
    """How a robot file names a file: package://NAME/... when it lies in a package on the search
    path (example-robot-data's do), else relative to the robot file."""
    path = path.resolve()
    for folder in package_search_path():
        if path.is_relative_to(folder.resolve()):
            return f"package://{path.relative_to(folder.resolve()).as_posix()}"
    return os.path.relpath(path, output.resolve().parent)


# The range a continuous arm joint is planned in when `robot init` writes the file: two turns
# about zero, which a user narrows to what the cables allow.
TWO_TURNS = round(2 * math.pi, 4)
# The velocity written for a continuous joint whose URDF has no <limit> (rad/s), said to be a guess.
GUESSED_VELOCITY = 1.0


def write_starting_file(urdf_name: str, srdf_name: str | None, output: Path) -> str:
    """Write a robot file for a URDF (and SRDF), paths or package:// URIs, to `output`, check it
    loads, and say what it holds."""
    urdf = resolve_file(urdf_name, {}, Path.cwd(), "URDF file")
    srdf = None if srdf_name is None else resolve_file(srdf_name, {}, Path.cwd(), "SRDF file")
    text = read_text(urdf, "URDF file")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise HriplanError(f"{urdf}: not valid URDF XML ({exc})") from None
    tree = UrdfTree(root)
    if root.find("link/collision") is None:  # refused before a file is written for it
        raise HriplanError(f"{urdf}: {NO_COLLISION_SHAPES}")
    semantic = read_srdf(read_text(srdf, "SRDF file"), tree) if srdf else Srdf()
    shapeless = {
        el.get("name") for el in root.findall("link") if el.find("visual") is None and el.find("collision") is None
    }
    arms = _arms_from_srdf(tree, semantic) or _arm_from_urdf(tree, shapeless)
    limits = {
        el.get("name"): (float(el.find("limit").get("lower", 0.0)), float(el.find("limit").get("upper", 0.0)))
        for el in root.findall("joint")
        if el.find("limit") is not None
    }
    nearest_zero: dict[str, float] = {}  # the written ready posture, or else ...
    mid_range: dict[str, float] = {}  # ... this one, where that one touches itself
    ranges: dict[str, tuple[float, float]] = {}  # the arms' joints' ranges (continuous: two turns)
    turning: list[str] = []  # continuous arm joints: planned within TWO_TURNS (the file says so)
    not_taken = _chains_not_taken(tree, semantic, arms)
    for arm in arms.values():
        joints = _arm_joints(tree, semantic, arm)
        turning += [j for j in joints if tree.joints[j].type == "continuous"]
        tool = arm.get("tool", arm.get("tip"))
        arm["hand"] = _hand(text, tree, limits, tool, set(joints))
        arm["ik"] = _ik_kind(text, tree.joints[joints[0]].parent, tool, joints)
        arm_ranges = {j: (-TWO_TURNS, TWO_TURNS) if j in turning else limits.get(j, (0.0, 0.0)) for j in joints}
        ranges |= arm_ranges
        nearest_zero |= {j: float(np.clip(0.0, *arm_ranges[j])) for j in joints}
        mid_range |= {
            j: 0.0 if lower <= 0.0 <= upper else (lower + upper) / 2 for j, (lower, upper) in arm_ranges.items()
        }
    name = _identifier(root.get("name", ""))
    data = {
        "name": f"{name}_robot" if name in DESCRIPTIONS else name,
        "urdf": _reference(urdf, output),
        **({"srdf": _reference(srdf, output)} if srdf else {}),
        "arms": arms,
    }
    if not any(name == "ready" for name, _, _ in semantic.states):
        data["postures"] = {"ready": nearest_zero}
    header = f"# A robot file written by `hriplan robot init` from {urdf.name}: check it with `hriplan robot check`.\n"
    if turning:
        data["limits"] = {j: {"lower": -TWO_TURNS, "upper": TWO_TURNS} for j in turning}
        unlimited = [j for j in turning if j not in limits]
        for j in unlimited:
            data["limits"][j]["velocity"] = GUESSED_VELOCITY
        if unlimited:
            header += f"# The URDF gives {', '.join(unlimited)} no velocity limit: {GUESSED_VELOCITY} rad/s is a guess to check.\n"

    def write() -> None:
        write_atomically(
            output, header + yaml.safe_dump(data, sort_keys=False, default_flow_style=None) + STOPPING_TODO
        )

    write()
    description, dropped = _loaded_without_bad_grippers(output, arms, write)
    robot = load_robot(description.name)  # the same model whichever ready is written
    checker = CollisionChecker(robot, Scene())
    if "postures" in data:
        # `ready`: the first of these the robot does not touch itself in (the Panda's ranges' ends
        # nearest zero fold its hand onto its forearm, the Kinova's its forearm onto its upper arm).
        states = [values for name, values in description.postures.items() if name != "ready"]  # the SRDF's, in range
        candidates = [nearest_zero, *(nearest_zero | v for v in states), mid_range]
        free = next((c for c in candidates if not checker.in_collision(robot.configuration(c))), None)
        free = free or _nearest_free(checker, nearest_zero, ranges) or nearest_zero
        if free != nearest_zero:
            data["postures"] = {"ready": free}
            write()
            del DESCRIPTIONS[description.name]
            description = load_robot_file(output)
    wrote = f"wrote {output}: robot {description.name}, arms " + ", ".join(
        f"{arm} ({len(a.joints)} joints, tool {a.tool_frame}, IK {a.ik})" for arm, a in description.arms.items()
    )
    return "\n".join(
        [wrote, *semantic.ignored, *not_taken, *dropped, *_colliding_postures(checker, description.postures)]
    )


def _loaded_without_bad_grippers(
    output: Path, arms: dict[str, dict], write: Callable[[], None]
) -> tuple[RobotDescription, list[str]]:
    """The written file loaded; where an arm's guessed gripper does not load (fingers that turn
    about an axis the tool frame does not say how to close along: the PR2's), the arm is written
    with no hand and a line says why, so that init always writes a file that loads."""
    dropped = []
    while True:
        try:
            return load_robot_file(output), dropped
        except HriplanError as exc:
            arm = next(
                (a for a, spec in arms.items() if f": arms.{a}.hand: " in str(exc) and spec["hand"] != "none"), None
            )
            if arm is None:
                raise
            reason = str(exc).split(f": arms.{arm}.hand: ", 1)[1]
            fingers = ", ".join(arms[arm]["hand"]["gripper"])
            dropped.append(f"arm {arm}: hand none: its fingers ({fingers}) as a parallel gripper: {reason}")
            arms[arm]["hand"] = "none"
            write()
