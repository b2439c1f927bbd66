"""A corpus of bad inputs, every command and file kind: each gets one clear line and the right exit code.

Every case is written into a fresh directory from the table below and run in-process through
typer's CliRunner; a few run as real subprocesses (tracebacks, hangs, Ctrl-C). Each must exit 2
(bad input) or 1 (planning or validation failed), print exactly one line on stderr that names
the problem (progress lines, `... `, aside), raise no exception, and leave no partial file.
"""

from __future__ import annotations

import copy
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from hriplan.cli.main import app

ROOT = Path(__file__).parents[2]
SCENARIO = ROOT / "benchmarks" / "scenarios" / "a_ur5_upright_box.json"
KAUTHAM = ROOT / "tests" / "data" / "kautham_ur5_upright.xml"
DIR = object()  # a file entry that is a directory
BINARY = b"\x89PNG\r\n\x1a\n\x00\xff\xfe\x00binary\x00"

TASK = {
    "name": "corpus",
    "robot": "ur5",
    "objects": [
        {
            "name": "cup",
            "kind": "Cup",
            "fill_level": "Empty",
            "shape": {"type": "cylinder", "radius": 0.04, "height": 0.1},
            "pose": {"xyz": [0.5, 0.0, 0.8]},
        }
    ],
    "humans": [{"name": "bob", "role": "Bystander", "position": [1.5, 0.0], "yaw": 3.14}],
    "steps": [{"name": "move", "goal": {"joints": {"elbow_joint": 1.0}}}],
    "planning": {"time_limit": 2, "seed": 1},
}


def bare_ur5(name: str, more: str = "") -> str:
    """A robot file of example-robot-data's UR5 with what `robot init` gives it and `more`."""
    urdf = "package://example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"
    return f"name: {name}\nurdf: {urdf}\narms:\n  arm: {{base: base_link, tip: tool0}}\n{more}"


# A slab through the UR5 at its start: a dozen parts collide with it.
SLAB = {"name": "slab", "shape": {"type": "box", "size": [2.0, 2.0, 0.6]}, "pose": {"xyz": [0.0, 0.0, 0.5]}}


def task(**changes) -> str:
    """The base task with `changes` (dotted paths like `steps.0.goal`) applied, as YAML."""
    data = copy.deepcopy(TASK)
    for dotted, value in changes.items():
        *parents, last = dotted.split("__")
        node = data
        for key in parents:
            node = node[int(key)] if isinstance(node, list) else node[key]
        if isinstance(node, list):
            node[int(last)] = value
        elif value is _DELETE:
            del node[last]
        else:
            node[last] = value
    return yaml.safe_dump(data, sort_keys=False)


_DELETE = object()


def problem(**changes) -> str:
    data = json.loads(SCENARIO.read_text())
    for dotted, value in changes.items():
        *parents, last = dotted.split("__")
        node = data
        for key in parents:
            node = node[int(key)] if isinstance(node, list) else node[key]
        node[last] = value
    return json.dumps(data)


def kautham(old: str, new: str) -> str:
    text = KAUTHAM.read_text()
    assert old in text
    return text.replace(old, new)


RULE_OK = "# Why the rule is there.\n[corpus_rule]\n    Task(?t) ^ involves(?t, ?h) ^ Bystander(?h)\n    -> isConstrainedBy(?h, KeepOutBystander)\n"


@dataclass
class Case:
    id: str
    argv: list[str]
    files: dict[str, object] = field(default_factory=dict)
    says: str = ""  # a part of the one line (case-insensitive)
    code: int = 2
    absent: list[str] = field(default_factory=list)  # outputs that must not exist afterwards


def C(id: str, argv: str, says: str = "", code: int = 2, absent: tuple[str, ...] = (), **files: object) -> Case:
    return Case(id, argv.split(), {k.replace("__", "."): v for k, v in files.items()}, says, code, list(absent))


# Trajectory mutations are applied to a real trajectory file (made once per session).
def _backwards(t: dict) -> None:
    t["points"][3]["time_from_start"] = t["points"][1]["time_from_start"] - 0.01


def _nan_position(t: dict) -> None:
    t["points"][2]["positions"][0] = math.nan


def _nan_time(t: dict) -> None:
    t["points"][2]["time_from_start"] = math.nan


def _inf_velocity(t: dict) -> None:
    t["points"][2]["velocities"][0] = math.inf


def _short_positions(t: dict) -> None:
    t["points"][2]["positions"] = t["points"][2]["positions"][:3]


def _no_points(t: dict) -> None:
    t["points"] = []


def _one_point_moving(t: dict) -> None:
    t["points"] = t["points"][2:3]
    t["points"][0]["time_from_start"] = 0.0


def _unknown_robot(t: dict) -> None:
    t["robot"] = "pr2"


def _unknown_joint(t: dict) -> None:
    t["joint_names"][0] = "knee_joint"


def _schema_version(t: dict) -> None:
    t["schema_version"] = 7


def _wrong_schema(t: dict) -> None:
    t["schema"] = "hriplan.task"


def _first_time_not_zero(t: dict) -> None:
    t["points"][0]["time_from_start"] = -1.0


def _repeated_time(t: dict) -> None:
    t["points"][3]["time_from_start"] = t["points"][2]["time_from_start"]


def _jump(t: dict) -> None:
    t["points"][5]["positions"][2] += 2.0


def _beyond_limit(t: dict) -> None:
    for p in t["points"][4:8]:
        p["positions"][2] = 7.0


TRAJECTORY_MUTATIONS = {
    "times_backwards": (_backwards, "time"),
    "nan_position": (_nan_position, "nan"),
    "nan_time": (_nan_time, "nan"),
    "inf_velocity": (_inf_velocity, "inf"),
    "short_positions": (_short_positions, "positions"),
    "no_points": (_no_points, "points"),
    "one_point_moving": (_one_point_moving, "at rest"),
    "unknown_robot": (_unknown_robot, "pr2"),
    "unknown_joint": (_unknown_joint, "knee_joint"),
    "schema_version": (_schema_version, "schema_version"),
    "wrong_schema": (_wrong_schema, "schema"),
    "negative_start_time": (_first_time_not_zero, "time"),
    "repeated_time": (_repeated_time, "time"),
}

GOAL = "steps__0__goal"
QUAT2 = {"tool_pose": {"xyz": [0.4, 0.1, 0.9], "quat_xyzw": [0, 0, 0, 2]}}

CASES: list[Case] = [
    # --- task files: reading ---
    C("task_missing", "constraints {d}/nope.yaml", "no such file"),
    C("task_directory", "constraints {d}/t.yaml", "directory", t__yaml=DIR),
    C("task_binary_yaml", "constraints {d}/t.yaml", "not a text file", t__yaml=BINARY),
    C("task_binary_json", "constraints {d}/t.json", "not a text file", t__json=BINARY),
    C(
        "task_latin1",
        "constraints {d}/t.yaml",
        "line 1: not valid UTF-8 text",
        t__yaml="name: caf\xe9\n".encode("latin-1"),
    ),
    C("task_empty", "constraints {d}/t.yaml", "the file is empty", t__yaml=""),
    C(
        "task_yaml_syntax",
        "constraints {d}/t.yaml",
        "line 3: not valid YAML",
        t__yaml="name: x\nsteps: [\n  - {goal: }\n",
    ),
    C("task_json_syntax", "constraints {d}/t.json", "not valid JSON", t__json='{"name": "x",}'),
    C(
        "task_top_list",
        "constraints {d}/t.yaml",
        "expected a mapping of fields at the top level, got list",
        t__yaml="- 1\n- 2\n",
    ),
    C(
        "task_top_scalar",
        "constraints {d}/t.yaml",
        "expected a mapping of fields at the top level, got str",
        t__yaml="hello\n",
    ),
    C(
        "task_duplicate_key",
        "constraints {d}/t.yaml",
        "line 7: key 'fill_level' is given twice",
        t__yaml=task().replace("fill_level: Empty", "fill_level: Full\n  fill_level: Empty"),
    ),
    C(
        "task_duplicate_top_key",
        "constraints {d}/t.yaml",
        "line 3: key 'robot' is given twice (first at line 1)",
        t__yaml="robot: ur5\n" + task(),
    ),
    C(
        "task_yaml_tab",
        "constraints {d}/t.yaml",
        "line 2: not valid YAML (found character '\\t'",
        t__yaml="name: x\n\tsteps: []\n",
    ),
    C("task_plan_missing", "plan {d}/nope.yaml -q", "no such file"),
    C("task_plan_binary", "plan {d}/t.yaml -q", "not a text file", t__yaml=BINARY),
    C("task_explain_binary", "explain {d}/t.yaml", "not a text file", t__yaml=BINARY),
    C("task_explain_directory", "explain {d}/t.yaml", "directory", t__yaml=DIR),
    # --- task files: content ---
    C(
        "task_unknown_key",
        "constraints {d}/t.yaml",
        "t.yaml: colour: Extra inputs are not permitted",
        t__yaml=task(colour="red"),
    ),
    C("task_no_steps", "constraints {d}/t.yaml", "steps: Field required", t__yaml=task(steps=_DELETE)),
    C("task_empty_steps", "constraints {d}/t.yaml", "steps: List should have at least 1 item", t__yaml=task(steps=[])),
    C(
        "task_unknown_robot",
        "constraints {d}/t.yaml",
        "robot: unknown robot 'pr2'; known robots: madar, ur5",
        t__yaml=task(robot="pr2"),
    ),
    C(
        # `robot init` writes no stopping data (a deployment measures its own): planning near a
        # person needs it, and says where it goes.
        "task_robot_file_without_stopping",
        "plan {d}/t.yaml -o {d}/out.json",
        "robot arm_without_stopping has no ISO/TS 15066 stopping data: give its robot file 'stopping:",
        absent=("out.json",),
        arm__yaml=bare_ur5("arm_without_stopping", "postures:\n  ready: {shoulder_lift_joint: -1.57}\n"),
        t__yaml=task(robot="arm.yaml", objects=[]),
    ),
    C(
        "task_robot_file_without_postures",
        "constraints {d}/t.yaml",
        "start.posture: robot 'arm_without_postures' has no posture 'ready'; postures: none (a robot file's `postures`",
        arm__yaml=bare_ur5("arm_without_postures"),
        t__yaml=task(robot="arm.yaml", objects=[]),
    ),
    C(
        "task_bad_hand_posture",
        "constraints {d}/t.yaml",
        "t.yaml: hands.right: unknown hand posture 'fist'; choose one of open, power, pinch, release",
        t__yaml=task(robot="madar", hands={"right": "fist"}),
    ),
    C(
        "task_object_no_kind",
        "constraints {d}/t.yaml",
        "objects.0.kind: Field required",
        t__yaml=task(objects=[{"name": "cup"}]),
    ),
    C(
        "task_object_unknown_field",
        "constraints {d}/t.yaml",
        "objects.0.colour: Extra inputs are not permitted",
        t__yaml=task(objects__0__colour="red"),
    ),
    C(
        "task_object_two_holders",
        "constraints {d}/t.yaml",
        "objects.0: object 'cup' cannot be held by the robot and by 'bob' at once",
        t__yaml=task(objects__0__held_by="arm", objects__0__in_hand_of="bob"),
    ),
    C(
        "task_held_by_an_arm_the_robot_lacks",
        "constraints {d}/t.yaml",
        "object 'cup' is held by arm 'right'; robot 'ur5' has the arms arm",
        t__yaml=task(objects__0__held_by="right"),
    ),
    C(
        "task_held_by_unknown_field",
        "constraints {d}/t.yaml",
        "objects.0.held_by.grip: Extra inputs are not permitted",
        t__yaml=task(objects__0__held_by={"arm": "arm", "grip": "top"}),
    ),
    C(
        "task_held_by_a_grasp_without_a_hand",
        "constraints {d}/t.yaml",
        "cup is held by TopGrasp, but ur5_arm has no robot hand to hold it by a grasp",
        t__yaml=task(objects__0__held_by={"arm": "arm", "grasp": "TopGrasp"}),
    ),
    C(
        "task_in_hand_of_nobody",
        "constraints {d}/t.yaml",
        "object 'cup' is in the hand of 'zoe', who is not among the humans",
        t__yaml=task(objects__0__in_hand_of="zoe"),
    ),
    C(
        "task_repeated_names",
        "constraints {d}/t.yaml",
        "names must be unique; repeated: cup",
        t__yaml=task(humans__0__name="cup"),
    ),
    C(
        "task_bad_fill_level",
        "constraints {d}/t.yaml",
        "objects.0.fill_level: Input should be 'Full', 'Partial' or 'Empty'",
        t__yaml=task(objects__0__fill_level="Half"),
    ),
    C(
        "task_bad_name",
        "constraints {d}/t.yaml",
        "objects.0.name: String should match pattern",
        t__yaml=task(objects__0__name="my cup"),
    ),
    C(
        "task_bad_object_quat",
        "constraints {d}/t.yaml",
        "objects.0.pose.quat_xyzw: quaternion [0.0, 0.0, 0.0, 0.0] is not a unit quaternion",
        t__yaml=task(objects__0__pose={"xyz": [0.5, 0, 0.8], "quat_xyzw": [0, 0, 0, 0]}),
    ),
    C(
        "task_bad_object_xyz",
        "constraints {d}/t.yaml",
        "objects.0.pose.xyz.2: Field required",
        t__yaml=task(objects__0__pose={"xyz": [0.5, 0]}),
    ),
    C(
        "task_bad_shape",
        "constraints {d}/t.yaml",
        "objects.0.shape: Input tag 'blob' found using 'type' does not match",
        t__yaml=task(objects__0__shape={"type": "blob"}),
    ),
    C(
        "task_negative_radius",
        "constraints {d}/t.yaml",
        "objects.0.shape.cylinder.radius: Input should be greater than 0",
        t__yaml=task(objects__0__shape={"type": "cylinder", "radius": -1, "height": 0.1}),
    ),
    C(
        "task_bad_role",
        "constraints {d}/t.yaml",
        "humans.0.role: Input should be 'Receiver'",
        t__yaml=task(humans__0__role="Spectator"),
    ),
    C(
        "task_bad_position",
        "constraints {d}/t.yaml",
        "humans.0.position.1: Field required",
        t__yaml=task(humans__0__position=[1.0]),
    ),
    C(
        "task_nan_yaw",
        "constraints {d}/t.yaml",
        "humans.0.yaw: Input should be a finite number",
        t__yaml=task(humans__0__yaw=".nan").replace("'.nan'", ".nan"),
    ),
    C(
        "task_bad_hand_side",
        "constraints {d}/t.yaml",
        "humans.0.hand: Input should be 'left' or 'right'",
        t__yaml=task(humans__0__hand="middle"),
    ),
    C(
        "task_negative_table",
        "constraints {d}/t.yaml",
        "scene.tables.0.size.1: Input should be greater than 0",
        t__yaml=task(scene={"tables": [{"position": [0.5, 0], "size": [0.5, -0.5, 0.04]}]}),
    ),
    C(
        "task_zero_table_top",
        "constraints {d}/t.yaml",
        "scene.tables.0.top: Input should be greater than 0",
        t__yaml=task(scene={"tables": [{"position": [0.5, 0], "top": 0}]}),
    ),
    C(
        "task_scene_unknown",
        "constraints {d}/t.yaml",
        "scene.walls: Extra inputs are not permitted",
        t__yaml=task(scene={"walls": []}),
    ),
    C(
        "task_bad_start_posture",
        "constraints {d}/t.yaml",
        "t.yaml: start.posture: robot 'ur5' has no posture 'dance'; postures: home, ready",
        t__yaml=task(start={"posture": "dance"}),
    ),
    C(
        "task_goal_and_goals",
        "constraints {d}/t.yaml",
        "steps.0: a step has either `goal` or `goals`",
        t__yaml=task(steps__0__goals=[{"joints": {"elbow_joint": 1.0}}], steps__0__arms=["arm"]),
    ),
    C(
        "task_no_goal",
        "constraints {d}/t.yaml",
        "steps.0: a step has either `goal` or `goals`",
        t__yaml=task(steps=[{"name": "move"}]),
    ),
    C(
        "task_goals_no_arms",
        "constraints {d}/t.yaml",
        "steps.0: `goals` needs `arms` with one arm per goal",
        t__yaml=task(steps=[{"name": "move", "goals": [{"joints": {"elbow_joint": 1.0}}]}]),
    ),
    C(
        "task_goal_unknown_kind",
        "constraints {d}/t.yaml",
        "steps.0: goal {fly} needs exactly one of the keys",
        t__yaml=task(**{GOAL: {"fly": "cup"}}),
    ),
    C(
        "task_goal_not_mapping",
        "constraints {d}/t.yaml",
        "steps.0.goal: a goal is a mapping with exactly one of the keys",
        t__yaml=task(**{GOAL: "home"}),
    ),
    C(
        "task_goal_two_kinds",
        "constraints {d}/t.yaml",
        "steps.0: goal {grasp, joints} needs exactly one of the keys",
        t__yaml=task(**{GOAL: {"grasp": "cup", "joints": {}}}),
    ),
    C(
        "task_grasp_unknown",
        "constraints {d}/t.yaml",
        "steps.0: grasp 'plate' is not among the objects",
        t__yaml=task(**{GOAL: {"grasp": "plate"}}),
    ),
    C(
        "task_hand_over_unknown_person",
        "constraints {d}/t.yaml",
        "steps.0: to 'zoe' is not among the humans",
        t__yaml=task(**{GOAL: {"hand_over": "cup", "to": "zoe"}}),
    ),
    C(
        "task_hand_over_no_to",
        "constraints {d}/t.yaml",
        "steps.0.goal.hand_over.to: Field required",
        t__yaml=task(**{GOAL: {"hand_over": "cup"}}),
    ),
    C(
        "task_take_no_from",
        "constraints {d}/t.yaml",
        "steps.0.goal.take.from: Field required",
        t__yaml=task(**{GOAL: {"take": "cup"}}),
    ),
    C(
        "task_place_no_at",
        "constraints {d}/t.yaml",
        "steps.0.goal.place.at: Field required",
        t__yaml=task(**{GOAL: {"place": "cup"}}),
    ),
    C(
        "task_insert_unknown_hole",
        "constraints {d}/t.yaml",
        "steps.0: into 'hole' is not among the objects",
        t__yaml=task(**{GOAL: {"insert": "cup", "into": "hole"}}),
    ),
    C(
        "task_quat_not_unit",
        "constraints {d}/t.yaml",
        "steps.0.goal.tool_pose.quat_xyzw: quaternion [0.0, 0.0, 0.0, 2.0] is not a unit quaternion",
        t__yaml=task(**{GOAL: QUAT2}),
    ),
    C(
        "task_quat_short",
        "constraints {d}/t.yaml",
        "steps.0.goal.tool_pose.quat_xyzw.3: Field required",
        t__yaml=task(**{GOAL: {"tool_pose": {"xyz": [0.4, 0.1, 0.9], "quat_xyzw": [0, 0, 1]}}}),
    ),
    C(
        "task_tool_pose_nan",
        "constraints {d}/t.yaml",
        "steps.0.goal.tool_pose.xyz: pose values must be finite numbers, got [0.4, nan, 0.9]",
        t__yaml=task(**{GOAL: {"tool_pose": {"xyz": [0.4, "nan", 0.9]}}}).replace("'nan'", ".nan"),
    ),
    C(
        "task_tool_pose_inf",
        "constraints {d}/t.yaml",
        "steps.0.goal.tool_pose.xyz: pose values must be finite numbers, got [0.4, inf, 0.9]",
        t__yaml=task(**{GOAL: {"tool_pose": {"xyz": [0.4, "inf", 0.9]}}}).replace("'inf'", ".inf"),
    ),
    C(
        "task_free_axis_bad",
        "constraints {d}/t.yaml",
        "steps.0.goal.tool_pose.free_axes.0: Input should be 'x', 'y' or 'z'",
        t__yaml=task(**{GOAL: {"tool_pose": {"xyz": [0.4, 0.1, 0.9]}, "free_axes": ["w"]}}),
    ),
    C(
        "task_joint_value_string",
        "constraints {d}/t.yaml",
        "steps.0.goal.joints.elbow_joint: Input should be a valid number",
        t__yaml=task(**{GOAL: {"joints": {"elbow_joint": "up"}}}),
    ),
    C(
        "task_joint_value_nan",
        "constraints {d}/t.yaml",
        "steps.0.goal.joints.elbow_joint: Input should be a finite number",
        t__yaml=task(**{GOAL: {"joints": {"elbow_joint": "nan"}}}).replace("'nan'", ".nan"),
    ),
    C(
        "task_joint_beyond_limit",
        "plan {d}/t.yaml -q -o {d}/out/t.json",
        "steps.0 (move): goal: elbow_joint = 10 rad is beyond its limits",
        absent=("out",),
        t__yaml=task(**{GOAL: {"joints": {"elbow_joint": 10.0}}}),
    ),
    C(
        "task_body_reach_without_height",
        "constraints {d}/t.yaml",
        "humans.0.reach.right.body.up: Field required",
        t__yaml=task(humans__0__reach={"right": {"forward": 0.3}}),
    ),
    C(
        "task_body_reach_unknown_direction",
        "constraints {d}/t.yaml",
        "humans.0.reach.right.body.ahead: Extra inputs are not permitted",
        t__yaml=task(humans__0__reach={"right": {"ahead": 0.3, "up": 1.0}}),
    ),
    C(
        "task_reach_neither_form",
        "constraints {d}/t.yaml",
        "humans.0.reach.left: a reach is a world point [x, y, z] or, relative to the body, {forward, left, up}",
        t__yaml=task(humans__0__reach={"left": "near"}),
    ),
    C(
        "task_body_reach_out_of_arm",
        "plan {d}/t.yaml -q -o {d}/out/t.json",
        "bob's right hand cannot reach",
        absent=("out",),
        t__yaml=task(humans__0__reach={"right": {"forward": 2.0, "up": 1.0}}),
    ),
    C(
        "task_person_inside_the_robot",
        "plan {d}/t.yaml -q -o {d}/out/t.json",
        "bob overlaps the robot at the start: their ",
        absent=("out",),
        t__yaml=task(humans__0__position=[0.1, 0.0]),
    ),
    C(
        "problem_person_inside_the_robot",
        "solve {d}/p.json -o {d}/o.json",
        "human overlaps the robot at the start: their ",
        absent=("o.json",),
        p__json=problem(scene__humans=[{"name": "human", "position": [0.0, 0.1], "yaw": 0.0}]),
    ),
    C(
        "task_start_in_a_slab",
        "plan {d}/t.yaml -q -o {d}/out/t.json",
        "start is in collision: ",
        code=1,
        absent=("out",),
        t__yaml=task(scene={"obstacles": [SLAB]}),
    ),
    C(
        "task_joint_beyond_limit_constraints",
        "constraints {d}/t.yaml",
        "steps.0 (move): goal: elbow_joint = 10 rad is beyond its limits",
        t__yaml=task(**{GOAL: {"joints": {"elbow_joint": 10.0}}}),
    ),
    C(
        "task_joint_unknown",
        "constraints {d}/t.yaml",
        "steps.0 (move): goal: 'knee_joint' is not a joint of ur5",
        t__yaml=task(**{GOAL: {"joints": {"knee_joint": 1.0}}}),
    ),
    C(
        "task_start_joint_unknown",
        "constraints {d}/t.yaml",
        "start.joints: 'knee_joint' is not a joint of ur5",
        t__yaml=task(start={"joints": {"knee_joint": 0.1}}),
    ),
    C(
        "task_start_beyond_limit",
        "constraints {d}/t.yaml",
        "start.joints: elbow_joint = -9 rad is beyond its limits",
        t__yaml=task(start={"joints": {"elbow_joint": -9.0}}),
    ),
    C(
        "task_step_arm_unknown",
        "constraints {d}/t.yaml",
        "robot 'ur5' has no arm 'middle'",
        t__yaml=task(steps__0__arm="middle"),
    ),
    C(
        "task_steps_same_name",
        "constraints {d}/t.yaml",
        "step names must be unique (each names its trajectory); repeated: move",
        t__yaml=task(steps=[TASK["steps"][0], {"name": "move", "goal": {"joints": {"elbow_joint": 1.2}}}]),
    ),
    C(
        "task_step_names_collide_with_default",
        "constraints {d}/t.yaml",
        "step names must be unique (each names its trajectory); repeated: step2",
        t__yaml=task(
            steps=[
                {"name": "step2", "goal": {"joints": {"elbow_joint": 1.0}}},
                {"goal": {"joints": {"elbow_joint": 1.2}}},
            ]
        ),
    ),
    C(
        "task_time_limit_huge",
        "constraints {d}/t.yaml",
        "time_limit: Input should be less than or equal to 3600",
        t__yaml=task(planning={"time_limit": 1e9}),
    ),
    C(
        "task_time_limit_zero",
        "constraints {d}/t.yaml",
        "planning.time_limit: Input should be greater than 0",
        t__yaml=task(planning={"time_limit": 0}),
    ),
    C(
        "task_time_limit_negative",
        "constraints {d}/t.yaml",
        "planning.time_limit: Input should be greater than 0",
        t__yaml=task(planning={"time_limit": -3}),
    ),
    C(
        "task_time_limit_text",
        "constraints {d}/t.yaml",
        "planning.time_limit: Input should be a valid number",
        t__yaml=task(planning={"time_limit": "long"}),
    ),
    C(
        "task_speed_factor_above_one",
        "constraints {d}/t.yaml",
        "planning.safety_margin.speed_factor: Input should be less than or equal to 1",
        t__yaml=task(planning={"safety_margin": {"speed_factor": 1.5}}),
    ),
    C(
        "task_padding_negative",
        "constraints {d}/t.yaml",
        "planning.safety_margin.padding: Input should be greater than or equal to 0",
        t__yaml=task(planning={"safety_margin": {"padding": -0.1}}),
    ),
    C(
        "task_planner_unknown",
        "constraints {d}/t.yaml",
        "planning.planner: Input should be 'CBiRRT'",
        t__yaml=task(planning={"planner": "A*"}),
    ),
    C(
        "task_space_unknown",
        "constraints {d}/t.yaml",
        "planning.space: Input should be 'atlas'",
        t__yaml=task(planning={"space": "euclid"}),
    ),
    C(
        "task_seed_text",
        "constraints {d}/t.yaml",
        "planning.seed: Input should be a valid integer, unable to parse",
        t__yaml=task(planning={"seed": "one"}),
    ),
    C(
        "task_seed_float",
        "constraints {d}/t.yaml",
        "planning.seed: Input should be a valid integer, got a number with a fractional part",
        t__yaml=task(planning={"seed": 1.5}),
    ),
    C(
        "task_project_start_text",
        "constraints {d}/t.yaml",
        "planning.project_start: Input should be a valid boolean",
        t__yaml=task(planning={"project_start": "maybe"}),
    ),
    C(
        "task_planning_unknown",
        "constraints {d}/t.yaml",
        "planning.speed: Extra inputs are not permitted",
        t__yaml=task(planning={"speed": 2}),
    ),
    # --- rule files (named by a task) ---
    C("rules_missing", "constraints {d}/t.yaml", "no.rules", t__yaml=task(rule_files=["no.rules"])),
    C("rules_directory", "constraints {d}/t.yaml", "r.rules", t__yaml=task(rule_files=["r.rules"]), r__rules=DIR),
    C(
        "rules_binary",
        "constraints {d}/t.yaml",
        "not a text file",
        t__yaml=task(rule_files=["r.rules"]),
        r__rules=BINARY,
    ),
    C(
        "rules_syntax",
        "constraints {d}/t.yaml",
        "r.rules",
        t__yaml=task(rule_files=["r.rules"]),
        r__rules=RULE_OK.replace("->", "=>"),
    ),
    C(
        "rules_no_comment_and_syntax",
        "constraints {d}/t.yaml",
        "between body and head; also, rule 'corpus_rule' needs a '#' comment",
        t__yaml=task(rule_files=["r.rules"]),
        r__rules=RULE_OK.replace("# Why the rule is there.\n", "").replace("->", "=>"),
    ),
    C(
        "rules_duplicate_name",
        "constraints {d}/t.yaml",
        "already used",
        t__yaml=task(rule_files=["r.rules"]),
        r__rules=RULE_OK.replace("corpus_rule", "keep_out_bystander"),
    ),
    C(
        "rules_unknown_class",
        "constraints {d}/t.yaml",
        "Wizard",
        t__yaml=task(rule_files=["r.rules"]),
        r__rules=RULE_OK.replace("Bystander(?h)", "Wizard(?h)"),
    ),
    # --- planning problems (solve) ---
    C("problem_missing", "solve {d}/nope.json", "no such file"),
    C("problem_directory", "solve {d}/p.json", "directory", p__json=DIR),
    C("problem_binary", "solve {d}/p.json", "not a text file", p__json=BINARY),
    C("problem_empty", "solve {d}/p.json", "empty", p__json=""),
    C("problem_json_syntax", "solve {d}/p.json", "not valid JSON", p__json="{"),
    C("problem_top_list", "solve {d}/p.json", "mapping", p__json="[]"),
    C("problem_unknown_robot", "solve {d}/p.json", "unknown robot 'pr2'; known robots:", p__json=problem(robot="pr2")),
    C(
        "problem_time_limit_huge",
        "solve {d}/p.json",
        "options.time_limit: Input should be less than or equal to 3600",
        p__json=problem(options__time_limit=1e9),
    ),
    C(
        "problem_negative_tolerance",
        "solve {d}/p.json",
        "orientation.tolerance: Input should be greater than or equal to 0",
        p__json=problem(constraints__constraints__0__tolerance=-1),
    ),
    C(
        "problem_goal_beyond_limit",
        "solve {d}/p.json -o {d}/o.json",
        "goal: elbow_joint = 10 rad is beyond its limits",
        absent=("o.json",),
        p__json=problem(goal__values__elbow_joint=10.0),
    ),
    C(
        "problem_start_beyond_limit",
        "solve {d}/p.json",
        "start: elbow_joint = 10 rad is beyond its limits",
        p__json=problem(start__elbow_joint=10.0),
    ),
    C(
        "problem_start_unknown_joint",
        "solve {d}/p.json",
        "start: 'knee_joint' is not a joint of ur5",
        p__json=problem(start__knee_joint=0.0),
    ),
    C("problem_goal_nan", "solve {d}/p.json", "NaN", p__json=problem(goal__values__elbow_joint=math.nan)),
    C(
        "problem_invalid_start",
        "solve {d}/p.json -o {d}/o.json",
        "planning failed",
        code=1,
        absent=("o.json",),
        p__json=problem(start__wrist_2_joint=-1.0),
    ),
    C("problem_output_under_file", "solve {d}/p.json -o {d}/afile/o.json", "afile", afile="x", p__json=problem()),
    C("problem_output_is_directory", "solve {d}/p.json -o {d}/out", "directory", out=DIR, p__json=problem()),
    C("solve_seed_text", "solve {d}/p.json --seed one", "seed", p__json=problem()),
    # --- trajectories: validate, view, plot (mutations below) ---
    C("traj_missing_validate", "validate {d}/nope.json", "no such file"),
    C("traj_missing_view", "view {d}/nope.json -o {d}/v.html", "no such file", absent=("v.html",)),
    C("traj_missing_plot", "plot {d}/nope.json -o {d}/plots", "no such file", absent=("plots",)),
    C("traj_directory", "validate {d}/tr.json", "directory", tr__json=DIR),
    C("traj_binary_validate", "validate {d}/tr.json", "not a text file", tr__json=BINARY),
    C("traj_binary_view", "view {d}/tr.json -o {d}/v.html", "not a text file", absent=("v.html",), tr__json=BINARY),
    C("traj_json_syntax", "validate {d}/tr.json", "not valid JSON", tr__json='{"points": [}'),
    C("traj_is_a_task", "validate {d}/tr.json", "joint_names", tr__json=json.dumps(TASK)),
    C("view_no_output", "view {d}/tr.json", "--output", tr__json="{}"),
    C("view_task_missing", "validate {d}/traj.json --task {d}/nope.yaml", "no such file", traj__json="TRAJECTORY"),
    C(
        "view_output_directory",
        "view {d}/traj.json -o {d}/outdir",
        "directory",
        traj__json="TRAJECTORY",
        outdir=DIR,
    ),
    C("view_output_under_file", "view {d}/traj.json -o {d}/afile/v.html", "afile", traj__json="TRAJECTORY", afile="x"),
    C("plot_output_is_file", "plot {d}/traj.json -o {d}/afile", "afile", traj__json="TRAJECTORY", afile="x"),
    C(
        "validate_task_other_step",
        "validate {d}/traj.json --task {d}/t.yaml",
        "step",
        traj__json="TRAJECTORY",
        t__yaml=task(),
    ),
    # --- SPARQL queries ---
    C("query_both", "query SELECT --file {d}/q.rq", "not both", q__rq="SELECT * WHERE {}"),
    C("query_neither", "query", "--file"),
    C("query_file_missing", "query --file {d}/nope.rq", "no such file"),
    C("query_file_directory", "query --file {d}/q.rq", "directory", q__rq=DIR),
    C("query_file_binary", "query --file {d}/q.rq", "not a text file", q__rq=BINARY),
    C("query_file_empty", "query --file {d}/q.rq", "SPARQL", q__rq="  \n"),
    C("query_syntax", "query --file {d}/q.rq", "SPARQL", q__rq="SELEKT ?x WHERE { ?x a ?y }"),
    C("query_bad_format", "query --file {d}/q.rq --format xml", "format", q__rq="SELECT * WHERE { ?s ?p ?o } LIMIT 1"),
    C(
        "query_task_binary",
        "query --file {d}/q.rq --task {d}/t.yaml",
        "not a text file",
        q__rq="SELECT * WHERE {}",
        t__yaml=BINARY,
    ),
    C(
        "query_unknown_step",
        "query --file {d}/q.rq --task {d}/t.yaml --step nope",
        "nope",
        q__rq="SELECT * WHERE { ?s ?p ?o } LIMIT 1",
        t__yaml=task(),
    ),
    C("query_update", "query --file {d}/q.rq", "updates are not supported", q__rq="INSERT DATA { <a:x> <a:y> <a:z> }"),
    # --- Kautham problems ---
    C("kautham_missing", "import-kautham {d}/nope.xml", "no such file"),
    C("kautham_directory", "import-kautham {d}/k.xml", "directory", k__xml=DIR),
    C("kautham_binary", "import-kautham {d}/k.xml", "XML", k__xml=BINARY),
    C(
        "kautham_latin1",
        "import-kautham {d}/k.xml -o {d}/o.json",
        "line 1: not valid UTF-8 text",
        absent=("o.json",),
        k__xml=b"<?xml version='1.0' encoding='utf-8'?><Problem>\xe9</Problem>",
    ),
    C("kautham_xml_syntax", "import-kautham {d}/k.xml", "not valid XML", k__xml="<Problem><Scene></Problem>"),
    C("kautham_no_robot", "import-kautham {d}/k.xml", "no <Robot> element", k__xml="<Problem><Scene/></Problem>"),
    C(
        "kautham_unsupported_robot",
        "import-kautham {d}/k.xml",
        "not supported",
        k__xml=kautham("robots/ur5.urdf", "robots/pr2.urdf"),
    ),
    C(
        "kautham_control_range",
        "import-kautham {d}/k.xml -o {d}/o.json",
        "normalised",
        absent=("o.json",),
        k__xml=kautham('init="0.687037"', 'init="1.7"'),
    ),
    C(
        "kautham_unknown_joint",
        "import-kautham {d}/k.xml",
        "query: control 'knee' is not in the problem file",
        k__xml=kautham('name="wrist_3_link" init', 'name="knee" init'),
    ),
    C(
        "kautham_bad_number",
        "import-kautham {d}/k.xml",
        "constraint 'workspace': 'long' is not 1 numbers",
        k__xml=kautham('length="0.8"', 'length="long"'),
    ),
    C("kautham_bad_rpy", "import-kautham {d}/k.xml --rpy euler", "rpy", k__xml=kautham("a", "a")),
    C(
        "kautham_output_under_file",
        "import-kautham {d}/k.xml -o {d}/afile/o.json",
        "afile",
        k__xml=kautham("a", "a"),
        afile="x",
    ),
    C(
        "kautham_output_directory",
        "import-kautham {d}/k.xml -o {d}/outdir",
        "directory",
        k__xml=kautham("a", "a"),
        outdir=DIR,
    ),
    # --- flags and outputs ---
    C("plan_no_args", "plan", "TASK"),
    C("plan_unknown_flag", "plan {d}/t.yaml --fast", "--fast", t__yaml=task()),
    C("plan_seed_text", "plan {d}/t.yaml --seed one", "seed", t__yaml=task()),
    C("plan_output_under_file", "plan {d}/t.yaml -q -o {d}/afile/x.json", "afile", t__yaml=task(), afile="x"),
    C("plan_output_directory", "plan {d}/t.yaml -q -o {d}/outdir", "directory", t__yaml=task(), outdir=DIR),
    C(
        "plan_html_under_file",
        "plan {d}/t.yaml -q -o {d}/x.json --html {d}/afile/x.html",
        "afile",
        absent=("x.json",),
        t__yaml=task(),
        afile="x",
    ),
    C(
        "plan_plots_is_file",
        "plan {d}/t.yaml -q -o {d}/x.json --plots {d}/afile",
        "afile",
        absent=("x.json",),
        t__yaml=task(),
        afile="x",
    ),
    # An output option's value missing: the next option is taken as its name (a page was once
    # written to a file named --plots).
    C(
        "plan_html_takes_an_option",
        "plan {d}/t.yaml -q -o {d}/x.json --html --plots",
        "--html --plots: looks like an option",
        absent=("x.json",),
        t__yaml=task(),
    ),
    C(
        "plan_plots_takes_an_option",
        "plan {d}/t.yaml -o {d}/x.json --plots -q",
        "--plots -q: looks like an option",
        absent=("x.json",),
        t__yaml=task(),
    ),
    C("constraints_extra_arg", "constraints {d}/t.yaml extra", "extra", t__yaml=task()),
    C("robot_info_unknown", "robot info pr2", "pr2"),
    C("robot_info_bad_hand", "robot info madar --hand right", "SIDE=POSTURE"),
    C("robot_info_bad_posture", "robot info madar --hand right=fist", "fist"),
    C("robot_info_bad_side", "robot info madar --hand middle=power", "middle"),
    C("robot_urdf_unknown", "robot urdf pr2", "pr2"),
    C("robot_urdf_mesh_dir_missing", "robot urdf ur5 --mesh-dir {d}/nope", "nope"),
    C("unknown_command", "fly", "fly"),
    C("schema_extra_arg", "schema extra", "extra"),
]

for _name, (_mutate, _says) in TRAJECTORY_MUTATIONS.items():
    for _command in ("validate", "view", "plot"):
        out = {"validate": "", "view": " -o {d}/v.html", "plot": " -o {d}/plots"}[_command]
        CASES.append(
            Case(
                f"traj_{_name}_{_command}",
                f"{_command} {{d}}/traj.json{out}".split(),
                {"traj.json": _name},
                _says,
                absent=["v.html", "plots"],
            )
        )


@pytest.fixture(scope="session")
def trajectory_text(tmp_path_factory) -> str:
    """A real trajectory file (UR5, solved once, with time to spare on a loaded machine), as text."""
    where = tmp_path_factory.mktemp("traj")
    (where / "p.json").write_text(problem(options__time_limit=60.0))
    out = where / "traj.json"
    result = CliRunner().invoke(app, ["solve", str(where / "p.json"), "--seed", "2", "-o", str(out)])
    assert result.exit_code == 0, result.output
    return out.read_text()


def _materialise(case: Case, d: Path, trajectory_text: str) -> list[str]:
    for name, content in case.files.items():
        path = d / name
        if content is DIR:
            path.mkdir()
        elif isinstance(content, bytes):
            path.write_bytes(content)
        elif content == "TRAJECTORY":
            path.write_text(trajectory_text)
        elif content in TRAJECTORY_MUTATIONS:
            data = json.loads(trajectory_text)
            TRAJECTORY_MUTATIONS[content][0](data)
            path.write_text(json.dumps(data))
        else:
            path.write_text(str(content))
    return [a.replace("{d}", str(d)) for a in case.argv]


def _files(d: Path) -> set[Path]:
    return {p.relative_to(d) for p in d.rglob("*")}


def _check(case: Case, d: Path, before: set[Path], code: int, stderr: str) -> None:
    # progress lines and warnings (e.g. a Kautham robot file that is not there) may come first
    lines = [line for line in stderr.splitlines() if line.strip() and not line.startswith(("... ", "warning: "))]
    assert "Traceback" not in stderr, stderr
    assert code == case.code, f"exit {code}, stderr: {stderr}"
    assert len(lines) == 1, f"not one line: {stderr!r}"
    assert case.says.lower() in lines[0].lower(), lines[0]
    after = _files(d)
    assert not [p for p in after if p.name.endswith(".tmp")], after
    for absent in case.absent:
        assert not (d / absent).exists() or Path(absent) in before, f"{absent} was written"
    assert not (after - before) or code == 0, f"written after a failure: {after - before}"


def test_the_corpus_is_large_and_distinct():
    assert len(CASES) >= 120
    assert len({c.id for c in CASES}) == len(CASES)
    assert all(c.says for c in CASES)  # each names its problem: no case accepts any one line


@pytest.mark.usefixtures("robot_registry")  # a case's robot file registers its robot: for that case only
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.id)
def test_bad_input(case: Case, tmp_path: Path, trajectory_text: str) -> None:
    argv = _materialise(case, tmp_path, trajectory_text)
    before = _files(tmp_path)
    cwd = os.getcwd()
    os.chdir(tmp_path)  # a default output (out/...) would land here
    try:
        result = CliRunner().invoke(app, argv)
    finally:
        os.chdir(cwd)
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    _check(case, tmp_path, before, result.exit_code, result.stderr)


SUBPROCESS_CASES = [
    "task_binary_yaml",
    "task_joint_beyond_limit",
    "kautham_directory",
    "view_output_directory",
    "traj_times_backwards_validate",
    "task_quat_not_unit",
    "plan_output_under_file",
    "query_file_binary",
]


def _cli(*args: str, cwd: Path, **kwargs) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    return subprocess.Popen(
        [sys.executable, "-m", "hriplan.cli", *args],
        cwd=cwd,
        env=env,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        **kwargs,
    )


@pytest.mark.parametrize("case", [c for c in CASES if c.id in SUBPROCESS_CASES], ids=lambda c: c.id)
def test_bad_input_as_a_real_process(case: Case, tmp_path: Path, trajectory_text: str) -> None:
    argv = _materialise(case, tmp_path, trajectory_text)
    before = _files(tmp_path)
    process = _cli(*argv, cwd=tmp_path)
    _, stderr = process.communicate(timeout=120)
    _check(case, tmp_path, before, process.returncode, stderr)


def test_ctrl_c_stops_planning_within_a_second(tmp_path: Path) -> None:
    """An optimising planner uses its whole minute; SIGINT while it runs (inside OMPL's C++ solve)
    stops the command within a second: exit 130, one line, no output file."""
    task_file = tmp_path / "t.yaml"
    task_file.write_text(task(planning={"time_limit": 60, "seed": 1, "planner": "RRTstar"}))
    process = _cli("plan", str(task_file), "-o", str(tmp_path / "out" / "t.json"), cwd=tmp_path)
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(process.stderr), daemon=True)
    reader.start()
    deadline = time.monotonic() + 90
    while not any("planning" in line for line in lines):
        assert process.poll() is None and time.monotonic() < deadline, lines
        time.sleep(0.1)
    time.sleep(1.0)  # well inside OMPL's solve
    sent = time.monotonic()
    process.send_signal(signal.SIGINT)
    process.wait(timeout=10)
    assert time.monotonic() - sent < 1.0
    reader.join(timeout=5)
    assert process.returncode == 130
    assert [line for line in lines if not line.startswith("... ")] == ["interrupted\n"]
    assert not (tmp_path / "out").exists() and not list(tmp_path.rglob("*.tmp"))


def test_explain_of_a_problems_trajectory_says_no_rule_made_its_constraints(tmp_path: Path, trajectory_text: str):
    """A planning problem's constraints come from its file, not from rules: `explain` says so for
    each instead of printing empty rules and facts."""
    (tmp_path / "traj.json").write_text(trajectory_text)
    result = CliRunner().invoke(app, ["explain", str(tmp_path / "traj.json")])
    assert result.exit_code == 0, result.output
    ids = [c["spec"]["id"] for c in json.loads(trajectory_text)["constraints"]]
    assert ids and result.stdout.count("no rule made it (a planning problem's constraint)") == len(ids)
    assert all(f"{i}: " in result.stdout for i in ids) and "kind:" not in result.stdout
