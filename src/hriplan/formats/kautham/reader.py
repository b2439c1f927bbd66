"""Reading Kautham's XML files: errors that name the file and the element, file search, poses."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from hriplan import HriplanError
from hriplan.files import read_text
from hriplan.robots.spatial import Pose


class Reader:
    """Attribute access that names the element and the file when something is missing."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, message: str) -> HriplanError:
        return HriplanError(f"{self.path}: {message}")

    def parse(self) -> ET.Element:
        text = read_text(self.path, "Kautham XML file")  # missing, a folder, binary: one line
        try:
            return ET.fromstring(text)
        except ET.ParseError as exc:
            raise self.fail(f"not valid XML ({exc})") from None

    def child(self, el: ET.Element, tag: str, where: str) -> ET.Element:
        found = el.find(tag)
        if found is None:
            raise self.fail(f"{where}: missing <{tag}>")
        return found

    def attr(self, el: ET.Element, name: str, where: str) -> str:
        value = el.get(name)
        if value is None:
            raise self.fail(f"{where}: <{el.tag}> has no attribute {name!r}")
        return value

    def floats(self, text: str, count: int, where: str) -> list[float]:
        try:
            values = [float(v) for v in text.split()]
        except ValueError:
            raise self.fail(f"{where}: {text!r} is not {count} numbers") from None
        if len(values) != count or not all(math.isfinite(v) for v in values):
            raise self.fail(f"{where}: {text!r} is not {count} finite numbers")
        return values

    def number(self, el: ET.Element, name: str, where: str, default: float | None = None) -> float:
        text = el.get(name)
        if text is None:
            if default is None:
                raise self.fail(f"{where}: <{el.tag}> has no attribute {name!r}")
            return default
        return self.floats(text, 1, where)[0]

    def home(self, el: ET.Element | None, where: str) -> Pose:
        """Kautham's `<Home X Y Z WX WY WZ TH/>`: a position and the quaternion
        (W sin(TH/2), cos(TH/2)) normalised, as Kautham builds it (a zero axis is no rotation)."""
        if el is None:
            return Pose()
        xyz = tuple(self.number(el, k, where, 0.0) for k in ("X", "Y", "Z"))
        axis = np.array([self.number(el, k, where, 0.0) for k in ("WX", "WY", "WZ")])
        angle = self.number(el, "TH", where, 0.0)
        quat = np.r_[axis * math.sin(angle / 2.0), math.cos(angle / 2.0)]
        return Pose(xyz=xyz, quat_xyzw=tuple(quat / np.linalg.norm(quat)))


def find_file(name: str, folders: Sequence[Path]) -> Path | None:
    """The first folder that has `name` (Kautham looks in the problem's folder, then its models)."""
    for folder in folders:
        if (folder / name).is_file():
            return folder / name
    return None
