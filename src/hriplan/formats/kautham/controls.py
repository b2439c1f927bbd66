"""Kautham's controls file (`.cntr`): how a query's normalised controls become joint angles.

As Kautham computes it (problem.cpp `setRobotControls`, robot.cpp `control2Parameters`): each
degree of freedom (DOF, named `ROBOT/LINK` by the link the joint moves) has an offset p0 in
[0, 1] (0.5 when the `<Offset>` block does not list it); control k moves DOF i by
M[i][k] = eigValue_k * value_ik. For controls c, DOF i's normalised value is
p_i = p0_i + sum_k M[i][k] (c_k - 0.5), and its angle lower_i + p_i (upper_i - lower_i) over
the joint's range in Kautham's robot model. So a joint that no control moves keeps its offset.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass
from pathlib import Path

from hriplan.formats.kautham.reader import Reader

BASE_DOFS = ("X", "Y", "Z", "X1", "X2", "X3")
DEFAULT_OFFSET = 0.5


@dataclass(frozen=True)
class ControlSet:
    """Offsets per joint and, per control (in file order), the weight on each joint it moves."""

    source: str
    offsets: Mapping[str, float]
    controls: Mapping[str, Mapping[str, float]]
    complete: bool = True  # a query must set every control (Kautham refuses it otherwise)

    def normalised(self, values: Mapping[str, float], joints: Collection[str]) -> dict[str, float]:
        """p per joint for control values c (a control the query does not set sits at 0.5)."""
        p = {joint: self.offsets.get(joint, DEFAULT_OFFSET) for joint in joints}
        for name, c in values.items():
            for joint, weight in self.controls[name].items():
                p[joint] += weight * (c - 0.5)
        return p


def implicit_controls(joint_of: Mapping[str, str]) -> ControlSet:
    """Without a controls file: one control per joint, named by the joint or the link it moves."""
    return ControlSet(
        "the problem file (no <Controls>)", {}, {name: {joint: 1.0} for name, joint in joint_of.items()}, False
    )


def read_controls(path: Path, robot_names: Collection[str], joint_of: Callable[[str], str | None]) -> ControlSet:
    """Read a `.cntr` file; DOFs must name this robot (`ROBOT/LINK`) and one of its moving links."""
    reader = Reader(path)
    root = reader.parse()
    if root.tag != "ControlSet":
        raise reader.fail(f"the root element is <{root.tag}>, not <ControlSet>")

    def dof(el: ET.Element, where: str) -> str:
        name = reader.attr(el, "name", where)
        robot, _, link = name.rpartition("/")
        if not robot:
            raise reader.fail(f"{where}: DOF {name!r} is not ROBOT/LINK")
        if robot not in robot_names:
            raise reader.fail(f"{where}: DOF {name!r} names robot {robot!r}, not {' or '.join(sorted(robot_names))}")
        if link in BASE_DOFS:
            raise reader.fail(
                f"{where}: DOF {name!r} moves the mobile base, which the importer does not plan (it places the base at <Home>)"
            )
        joint = joint_of(link)
        if joint is None:
            raise reader.fail(f"{where}: DOF {name!r}: the robot has no joint moving link {link!r}")
        return joint

    offsets = {}
    for el in root.findall("Offset/DOF"):
        where = f"offset {el.get('name')!r}"
        offsets[dof(el, where)] = reader.number(el, "value", where)
    controls: dict[str, dict[str, float]] = {}
    for el in root.findall("Control"):
        name = reader.attr(el, "name", "<Control>")
        where = f"control {name!r}"
        if name in controls:
            raise reader.fail(f"{where} is defined twice")
        eig = reader.number(el, "eigValue", f"{where}: eigValue", 1.0)
        weights: dict[str, float] = {}
        for dof_el in el.findall("DOF"):
            joint = dof(dof_el, where)
            weights[joint] = weights.get(joint, 0.0) + eig * reader.number(dof_el, "value", where)
        if not weights:
            raise reader.fail(f"{where} moves no DOF")
        controls[name] = weights
    if not controls:
        raise reader.fail("no <Control> elements")
    return ControlSet(str(path), offsets, controls)
