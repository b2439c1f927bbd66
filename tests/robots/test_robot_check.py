"""`hriplan robot init` and `hriplan robot check` on robots the code was not written for: the
starting file a URDF (and SRDF) gives loads and checks, and a bad robot file is one line, exit 2."""

from __future__ import annotations

import shutil
from pathlib import Path

import example_robot_data
import numpy as np
import pinocchio as pin
import pytest
import yaml
from tests.independent import nearest
from typer.testing import CliRunner

from hriplan.cli.main import app

ROBOTS = Path(example_robot_data.getModelPath("panda_description/urdf/panda.urdf")).resolve()
PANDA = ROBOTS / "panda_description"
DATA = Path(__file__).parents[1] / "data" / "robots"


pytestmark = pytest.mark.usefixtures("robot_registry")


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_init_from_the_panda_urdf_and_srdf_writes_a_file_that_checks(tmp_path):
    out = tmp_path / "panda.yaml"
    result = invoke(
        "robot", "init", "--urdf", PANDA / "urdf" / "panda.urdf", "--srdf", PANDA / "srdf" / "panda.srdf", "-o", out
    )
    assert result.exit_code == 0, result.output
    assert result.stdout.strip() == f"wrote {out}: robot panda, arms arm (7 joints, tool panda_hand_tcp, IK numeric)"
    data = yaml.safe_load(out.read_text())
    assert data["urdf"] == "package://example-robot-data/robots/panda_description/urdf/panda.urdf"
    assert data["arms"]["arm"] == {
        "group": "arm",
        "tool": "panda_hand_tcp",
        "hand": {"gripper": ["panda_finger_joint1", "panda_finger_joint2"], "open": 0.04, "closed": 0.0},
        "ik": "numeric",
    }
    # At zero (the ends of its ranges nearest zero) the Panda's hand folds onto its forearm: its
    # `ready` is the SRDF's `default` state, the first posture it does not touch itself in.
    assert data["postures"]["ready"] == {
        "panda_joint1": 0.0,
        "panda_joint2": -0.785398,
        "panda_joint3": 0.0,
        "panda_joint4": -2.35619,
        "panda_joint5": 0.0,
        "panda_joint6": 1.5707,
        "panda_joint7": 0.785398,
    }
    check = invoke("robot", "check", out)
    assert check.exit_code == 0, check.output
    lines = check.stdout.splitlines()
    assert not any(line.startswith("posture ") for line in lines)
    assert "SRDF groups: arm (7 joints), hand (1 joints), arm_and_hand (8 joints)" in lines
    rate = next(line for line in lines if line.startswith("arm arm: IK numeric: "))
    assert int(rate.split()[4]) >= 99  # of 100 random reachable poses
    assert "postures: default, ready" in lines
    # Its gripper closes along panda_hand_tcp's y: a cup held from the side stands along its x.
    assert any(
        line.endswith("hand parallel gripper, a side-grasped cup upright when tool +x points up") for line in lines
    )
    assert any(line.startswith("SRDF disabled pairs: 35: ") for line in lines)


def test_init_from_the_ur10_urdf_alone_finds_its_chain_and_analytic_solver(tmp_path):
    out = tmp_path / "ur10.yaml"
    uri = "package://example-robot-data/robots/ur_description/urdf/ur10_robot.urdf"
    result = invoke("robot", "init", "--urdf", uri, "-o", out)
    assert result.exit_code == 0, result.output
    assert yaml.safe_load(out.read_text())["arms"] == {
        "arm": {"base": "base_link", "tip": "tool0", "hand": "none", "ik": "ur10_analytic"}
    }
    check = invoke("robot", "check", out)
    assert check.exit_code == 0, check.output
    assert "arm arm: IK ur10_analytic: 100 of 100 random reachable poses solved" in check.stdout
    assert "SRDF: none (arms by base and tip links)" in check.stdout


@pytest.mark.parametrize(
    "arm, message",
    [
        ("{group: still}", "group 'still' has no joints that move"),
        ("{base: base, tip: nowhere}", "unknown link 'nowhere'"),
        ("{group: both}", "not a serial chain"),
        ("{group: a_only}", "no tool frame"),
    ],
)
def test_check_of_a_bad_robot_file_is_one_line_and_exit_2(tmp_path, arm, message):
    shutil.copytree(DATA / "fork", tmp_path, dirs_exist_ok=True)
    path = tmp_path / "fork.yaml"
    path.write_text(f"name: fork\nurdf: fork.urdf\nsrdf: fork.srdf\narms:\n  arm: {arm}\n")
    result = invoke("robot", "check", path)
    assert result.exit_code == 2 and result.stdout == ""
    assert result.stderr.count("\n") == 1 and message in result.stderr and str(path.name) in result.stderr


def test_check_of_a_missing_mesh_is_one_line_and_exit_2(tmp_path):
    shutil.copy(DATA / "fork" / "fork.urdf", tmp_path)  # without its meshes/ folder
    path = tmp_path / "fork.yaml"
    path.write_text("name: fork\nurdf: fork.urdf\narms:\n  arm: {base: base, tip: c}\n")
    result = invoke("robot", "check", path)
    assert result.exit_code == 2 and result.stderr.count("\n") == 1 and "missing mesh" in result.stderr


def test_init_of_a_missing_urdf_is_one_line_and_exit_2(tmp_path):
    result = invoke("robot", "init", "--urdf", tmp_path / "none.urdf", "-o", tmp_path / "x.yaml")
    assert result.exit_code == 2 and result.stderr.strip() == f"error: missing URDF file {tmp_path / 'none.urdf'}"
    assert not (tmp_path / "x.yaml").exists()


def test_robot_info_and_urdf_take_a_robot_file(tmp_path):
    info = invoke("robot", "info", DATA / "panda.yaml", "--hand", "arm=closed")
    assert info.exit_code == 0, info.output
    assert info.stdout.splitlines()[:3] == [
        "robot panda: 7 planning joints",
        "hands: arm closed",
        "group arm (7 joints)",
    ]
    exported = invoke("robot", "urdf", DATA / "ur10.yaml")
    assert exported.exit_code == 0, exported.output
    assert (
        'filename="package://example-robot-data/robots/ur_description/meshes/ur10/collision/base.stl"'
        in exported.stdout
    )
    (tmp_path / "ur10.urdf").write_text(exported.stdout)
    model = pin.buildModelFromUrdf(str(tmp_path / "ur10.urdf"))
    original = pin.buildModelFromUrdf(str(ROBOTS / "ur_description" / "urdf" / "ur10_robot.urdf"))
    q = np.random.default_rng(0).uniform(-1.0, 1.0, 6)
    poses = []
    for m in (model, original):
        data = m.createData()
        pin.framesForwardKinematics(m, data, q)
        poses.append(data.oMf[m.getFrameId("tool0")].homogeneous)
    assert np.abs(poses[0] - poses[1]).max() < 1e-12


@pytest.mark.parametrize(
    "urdf, name, kind",
    [("ur3_robot.urdf", "ur3", "ur3_analytic"), ("ur5_robot.urdf", "ur5_robot", "ur5_analytic")],
)
def test_init_picks_the_analytic_solver_that_fits_each_ur_arm(tmp_path, urdf, name, kind):
    # The UR5's name is a built-in robot's: the file's robot is named after the URDF's robot_.
    out = tmp_path / "robot.yaml"
    result = invoke(
        "robot", "init", "--urdf", f"package://example-robot-data/robots/ur_description/urdf/{urdf}", "-o", out
    )
    assert result.exit_code == 0, result.output
    assert result.stdout.strip() == f"wrote {out}: robot {name}, arms arm (6 joints, tool tool0, IK {kind})"


def _mesh_gap(urdf: Path, values: dict[str, float], links: set[str], others: set[str]) -> float:
    """The least distance between the URDF collision shapes of `links` and of `others` at the
    joint `values` (others at 0), straight from the URDF with pinocchio and coal."""
    model = pin.buildModelFromUrdf(str(urdf))
    geometry = pin.buildGeomFromUrdf(model, str(urdf), pin.COLLISION, package_dirs=[str(ROBOTS.parents[1])])
    q = pin.neutral(model)
    for name, value in values.items():
        q[model.joints[model.getJointId(name)].idx_q] = value
    data, gdata = model.createData(), geometry.createData()
    pin.updateGeometryPlacements(model, data, geometry, gdata, q)

    def link(g):
        return model.frames[g.parentFrame].name

    objects = list(zip(geometry.geometryObjects, gdata.oMg))
    return min(
        nearest(a.geometry, at_a, b.geometry, at_b).min_distance
        for a, at_a in objects
        if link(a) in links
        for b, at_b in objects
        if link(b) in others
    )


def test_init_from_a_urdf_alone_ends_the_arm_at_its_hand_and_starts_it_free(tmp_path):
    """TIAGo's URDF alone: the longest chain runs into the little finger of its five-finger hand.
    The arm ends where the fingers branch (the palm), its tool the URDF's grasp frame, the torso
    lift its first joint (the head branching off the torso does not cut the arm). At zero its arm
    lies in its torso column (on the meshes), as at mid-range: `ready` is the nearest posture
    it does not touch itself in."""
    urdf = ROBOTS / "tiago_description" / "robots" / "tiago.urdf"
    out = tmp_path / "tiago.yaml"
    result = invoke("robot", "init", "--urdf", urdf, "-o", out)
    assert result.exit_code == 0, result.output
    assert (
        result.stdout.strip() == f"wrote {out}: robot tiago, arms arm (8 joints, tool hand_grasping_frame, IK numeric)"
    )
    data = yaml.safe_load(out.read_text())
    assert data["arms"] == {
        "arm": {
            "base": "torso_fixed_link",
            "tip": "hand_palm_link",
            "tool": "hand_grasping_frame",
            "hand": "none",
            "ik": "numeric",
        }
    }
    assert "\n# stopping: {reaction_time: S, stopping_time: S" in out.read_text()  # to fill in, no guess
    ready = data["postures"]["ready"]
    assert sorted(ready) == sorted(["torso_lift_joint", *(f"arm_{k}_joint" for k in range(1, 8))])
    arm = {f"arm_{k}_link" for k in range(3, 8)} | {"hand_palm_link"}
    column = {"torso_fixed_column_link", "torso_fixed_link", "base_link"}
    assert _mesh_gap(urdf, dict.fromkeys(ready, 0.0), arm | {"arm_1_link", "arm_2_link"}, column) < 0.0
    assert _mesh_gap(urdf, ready, arm, column) > 0.0
    check = invoke("robot", "check", out)
    assert check.exit_code == 0, check.output
    assert not any(line.startswith("posture ") for line in check.stdout.splitlines())


def test_init_from_the_panda_urdf_alone_takes_its_fingers_as_the_gripper(tmp_path):
    """Without its SRDF the Panda's longest chain ended in a finger joint; now the arm ends at the
    hand the fingers branch from, the tool the URDF's panda_hand_tcp, the fingers its gripper."""
    out = tmp_path / "panda.yaml"
    result = invoke("robot", "init", "--urdf", PANDA / "urdf" / "panda.urdf", "-o", out)
    assert result.exit_code == 0, result.output
    assert yaml.safe_load(out.read_text())["arms"] == {
        "arm": {
            "base": "panda_link0",
            "tip": "panda_hand",
            "tool": "panda_hand_tcp",
            "hand": {"gripper": ["panda_finger_joint1", "panda_finger_joint2"], "open": 0.04, "closed": 0.0},
            "ik": "numeric",
        }
    }
    assert not any(line.startswith("posture ready: in self-collision") for line in result.stdout.splitlines())


def test_init_writes_a_file_that_loads_when_the_guessed_gripper_does_not(tmp_path):
    """The PR2's URDF alone: the fingers below its left palm turn about the palm's z axis, which a
    parallel gripper must be told how to close along. init wrote them as one and its own file did
    not load; it now writes the arm without a hand and says why, in one line of its output."""
    out = tmp_path / "pr2.yaml"
    result = invoke("robot", "init", "--urdf", ROBOTS / "pr2_description" / "urdf" / "pr2.urdf", "-o", out)
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0] == f"wrote {out}: robot pr2, arms arm (8 joints, tool l_gripper_palm_link, IK numeric)"
    assert lines[1].startswith("arm arm: hand none: its fingers (l_gripper_l_finger_joint, ")
    assert "does not close along the tool's x or y axis; say which: closes_along: x or y" in lines[1]
    assert yaml.safe_load(out.read_text())["arms"]["arm"]["hand"] == "none"
    assert not any(line.startswith("posture ready: in self-collision") for line in lines)


def test_an_srdf_state_of_a_joint_the_urdf_lacks_is_read_past_and_said(tmp_path):
    # TALOS's SRDF sets pinocchio's floating base `root_joint` (7 numbers) in its half_sitting
    # state; no URDF has it. srdfdom skips such a joint; so does hriplan, and says so.
    _fork_of_boxes(tmp_path)  # a one-joint arm's IK too
    (tmp_path / "fork.srdf").write_text(
        '<robot name="fork"><group name="arm"><chain base_link="base" tip_link="c"/></group>'
        '<group_state name="half" group="arm"><joint name="root_joint" value="0 0 1 0 0 0 1"/>'
        '<joint name="ja" value="0.5"/></group_state></robot>'
    )
    path = tmp_path / "fork.yaml"
    path.write_text("name: fork_state\nurdf: fork.urdf\nsrdf: fork.srdf\narms:\n  arm: {group: arm, tool: c}\n")
    result = invoke("robot", "check", path)
    assert result.exit_code == 0, result.output
    assert "SRDF group state 'half': 'root_joint' not in the URDF, ignored" in result.stdout
    assert "postures: half" in result.stdout
    assert "tool frame c; hand none, a held object upright when tool -z points up" in result.stdout
    from hriplan.robots.descriptions.registry import description_of

    assert description_of("fork_state").postures["half"] == {"ja": 0.5}


def test_check_of_an_unreadable_mesh_is_one_line_and_exit_2(tmp_path):
    shutil.copytree(DATA / "fork", tmp_path, dirs_exist_ok=True)  # meshes/d.stl: an STL with no facet
    path = tmp_path / "fork.yaml"
    path.write_text("name: fork_mesh\nurdf: fork.urdf\narms:\n  arm: {base: base, tip: c}\n")
    result = invoke("robot", "check", path)
    assert result.exit_code == 2 and result.stdout == "", result.output
    assert result.stderr.count("\n") == 1 and "does not load" in result.stderr and "d.stl" in result.stderr


def test_a_robot_without_collision_shapes_is_one_line_and_init_writes_nothing(tmp_path):
    """Every motion is checked against the robot's collision shapes: a URDF with visual shapes
    alone (fork.urdf without its mesh link) gave a traceback from the collision checker."""
    urdf = (DATA / "fork" / "fork.urdf").read_text()
    (tmp_path / "fork.urdf").write_text("\n".join(line for line in urdf.splitlines() if '"d"' not in line))
    out = tmp_path / "fork.yaml"
    result = invoke("robot", "init", "--urdf", tmp_path / "fork.urdf", "-o", out)
    assert result.exit_code == 2 and result.stderr.count("\n") == 1 and not out.exists(), result.output
    assert result.stderr.startswith(f"error: {tmp_path / 'fork.urdf'}: the URDF gives no link a <collision> shape")
    out.write_text("name: fork_bare\nurdf: fork.urdf\narms:\n  arm: {base: base, tip: c}\n")
    result = invoke("robot", "check", out)
    assert result.exit_code == 2 and result.stderr.count("\n") == 1, result.output
    assert "robot 'fork_bare': the URDF gives no link a <collision> shape" in result.stderr


def _fork_of_boxes(folder: Path) -> None:
    """fork.urdf in `folder` with a box on links a and b and without the mesh link d."""
    urdf = (DATA / "fork" / "fork.urdf").read_text()
    urdf = "\n".join(line for line in urdf.splitlines() if '"d"' not in line)
    for link, x in (("a", 0.3), ("b", -0.3)):
        box = f'<link name="{link}"><collision><origin xyz="{x} 0 0"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>'
        urdf = urdf.replace(f'<link name="{link}"/>', box)
    (folder / "fork.urdf").write_text(urdf)


def test_init_names_the_srdf_chains_it_did_not_take_as_arms(tmp_path):
    # TALOS's SRDF has end effectors on its feet only: init takes the legs as arms, and the arms
    # are groups the user must name. Here `leg` ends in an end effector and `arm` does not.
    _fork_of_boxes(tmp_path)
    (tmp_path / "fork.srdf").write_text(
        '<robot name="fork"><group name="leg"><chain base_link="base" tip_link="c"/></group>'
        '<group name="arm"><joint name="jb"/></group><group name="both"><group name="leg"/><group name="arm"/></group>'
        '<end_effector name="foot" parent_link="c" group="leg"/></robot>'
    )
    out = tmp_path / "fork.yaml"
    result = invoke("robot", "init", "--urdf", tmp_path / "fork.urdf", "--srdf", tmp_path / "fork.srdf", "-o", out)
    assert result.exit_code == 0, result.output
    assert yaml.safe_load(out.read_text())["arms"] == {
        "leg": {"group": "leg", "tool": "c", "hand": "none", "ik": "numeric"}
    }
    assert "SRDF groups not taken as arms: arm (1 joints, to b); one is an arm as" in result.stdout


def test_init_names_an_srdf_arm_that_shares_the_torso_joint_of_the_arm_it_took(tmp_path):
    """Centauro's SRDF has arm groups and no end effectors: init takes the longest chain, torso
    joint and right arm, and must still name the left arm, which turns with that torso joint (it
    was left out: its chain shares a joint with the arm taken). The torso group, part of the arm
    taken, and the right arm, the arm itself, are not named."""
    box = '<collision><geometry><box size="0.05 0.05 0.05"/></geometry></collision>'
    joints = [("jt", "base", "t", "0 0 0.5"), ("jl", "t", "l1", "0 0.2 0"), ("jl2", "l1", "l2", "0.3 0 0")]
    joints += [("jr", "t", "r1", "0 -0.2 0"), ("jr2", "r1", "r2", "0.3 0 0")]
    links = "".join(f'<link name="{n}">{box}</link>' for n in ("base", "t", "l1", "l2", "r1", "r2"))
    chain = "".join(
        f'<joint name="{j}" type="revolute"><parent link="{a}"/><child link="{b}"/><origin xyz="{xyz}"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>'
        for j, a, b, xyz in joints
    )
    (tmp_path / "centaur.urdf").write_text(f'<robot name="centaur">{links}{chain}</robot>')
    (tmp_path / "centaur.srdf").write_text(
        '<robot name="centaur"><group name="torso"><chain base_link="base" tip_link="t"/></group>'
        '<group name="left_arm"><chain base_link="t" tip_link="l2"/></group>'
        '<group name="right_arm"><chain base_link="t" tip_link="r2"/></group>'
        '<disable_collisions link1="base" link2="t" reason="Adjacent"/></robot>'
    )
    out = tmp_path / "centaur.yaml"
    result = invoke(
        "robot", "init", "--urdf", tmp_path / "centaur.urdf", "--srdf", tmp_path / "centaur.srdf", "-o", out
    )
    assert result.exit_code == 0, result.output
    assert yaml.safe_load(out.read_text())["arms"]["arm"]["tip"] == "r2"
    assert "SRDF groups not taken as arms: left_arm (2 joints, to l2); one is an arm as" in result.stdout


def _panda_fingers(folder: Path, finger1: tuple[str, str], finger2: tuple[str, str, str]) -> Path:
    """The Panda's URDF in `folder` with its fingers' axes and limits rewritten: (axis, limits) of
    finger 1, (axis, limits, mimic multiplier) of finger 2."""
    urdf = (PANDA / "urdf" / "panda.urdf").read_text()
    first, second = urdf.index('<joint name="panda_finger_joint1"'), urdf.index('<joint name="panda_finger_joint2"')
    parts = [urdf[:first], urdf[first:second], urdf[second:]]
    for k, (axis, limits) in ((1, finger1), (2, finger2[:2])):
        old_axis = '<axis xyz="0 1 0"/>' if k == 1 else '<axis xyz="0 -1 0"/>'
        parts[k] = parts[k].replace(old_axis, f'<axis xyz="{axis}"/>', 1)
        parts[k] = parts[k].replace('lower="0.0" upper="0.04"', limits, 1)
    mimic = f'<mimic joint="panda_finger_joint1" multiplier="{finger2[2]}"/>'
    parts[2] = parts[2].replace('<mimic joint="panda_finger_joint1"/>', mimic, 1)
    (folder / "panda.urdf").write_text("".join(parts))
    return folder / "panda.urdf"


@pytest.mark.parametrize(
    ("finger1", "finger2", "open_closed"),
    [
        # The second finger written as TIAGo Pro writes its fingertips: the same motion as a
        # mirror of the first (axis, limits and multiplier negated). Init wrote `hand: none`.
        (("0 1 0", 'lower="0.0" upper="0.04"'), ("0 1 0", 'lower="-0.04" upper="0.0"', -1), (0.04, 0.0)),
        # Both fingers closed at the upper end of their range, as TIAGo Pro's (0 open, 0.8
        # closed): init wrote them open where they touch.
        (("0 -1 0", 'lower="-0.04" upper="0.0"'), ("0 1 0", 'lower="-0.04" upper="0.0"', 1), (-0.04, 0.0)),
    ],
)
def test_init_reads_a_grippers_fingers_from_their_urdf(tmp_path, finger1, finger2, open_closed):
    urdf = _panda_fingers(tmp_path, finger1, finger2)
    out = tmp_path / "panda.yaml"
    result = invoke("robot", "init", "--urdf", urdf, "-o", out)
    assert result.exit_code == 0, result.output
    hand = yaml.safe_load(out.read_text())["arms"]["arm"]["hand"]
    assert hand["gripper"] == ["panda_finger_joint1", "panda_finger_joint2"]
    assert (hand["open"], hand["closed"]) == open_closed
