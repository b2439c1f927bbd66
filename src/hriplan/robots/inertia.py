"""Inertias for the links of a URDF that give none, or none a body can have, so that an exported
robot loads in simulators.

Gazebo drops a link without mass and ROS tooling (KDL, MoveIt's dynamics, physics engines) wants a
positive mass and a physical inertia on every link; hriplan plans kinematics only. Its built-in
URDFs state no inertia for the UR5 links, the torso, the wheels, the hand adapters and the tool
frames; upstream URDFs state some that are not physical (zero mass on the Panda's and UR10's
frames, the Allegro's last finger links before the tips, whose principal moments break the
triangle inequality).
A link with collision shapes (else visual shapes) gets the inertia of its shapes as solids of
DENSITY (each primitive exactly; a mesh by its closed surface, or its bounding box where the
surface encloses no volume), summed with overlaps counted twice; a link with no shape (a frame)
gets FRAME_MASS in a small solid sphere. A link whose stated mass is positive keeps that mass (the
inertia found is scaled to it); a physical stated <inertial> is kept as it is.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

from hriplan.robots.model import urdf_geometry

# kg/m^3: water's, a stand-in for links whose makers state no mass. Solid shapes of hollow links:
# the UR5's collision meshes at this density weigh 10.9 kg against its data sheet's 18.4 kg.
DENSITY = 1000.0
# A frame-only link (a tool frame): 1 g in a solid sphere of 1 cm radius (positive, negligible).
FRAME_MASS = 1e-3
FRAME_RADIUS = 0.01


def _solid(geometry: object) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume, centroid and inertia about the centroid at unit density of a coal shape, or of its
    bounding box when its surface encloses no volume (an open mesh)."""
    try:
        volume = float(geometry.computeVolume())
        com = np.asarray(geometry.computeCOM(), dtype=float)
        inertia = np.asarray(geometry.computeMomentofInertiaRelatedToCOM(), dtype=float)
        if volume > 0 and np.all(np.linalg.eigvalsh(inertia) > 0):
            return volume, com, inertia
    except (AttributeError, RuntimeError):
        pass
    geometry.computeLocalAABB()
    low, high = np.asarray(geometry.aabb_local.min_), np.asarray(geometry.aabb_local.max_)
    x, y, z = np.maximum(high - low, 1e-6)
    volume = x * y * z
    return volume, (low + high) / 2, volume / 12 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y])


def _link_inertias(model: pin.Model, shapes: pin.GeometryModel) -> dict[str, pin.Inertia]:
    """Per link with shapes, the inertia of its shapes in the link's frame."""
    found: dict[str, pin.Inertia] = {}
    for shape in shapes.geometryObjects:
        frame = model.frames[shape.parentFrame]
        volume, com, inertia = _solid(shape.geometry)
        solid = pin.Inertia(DENSITY * volume, com, DENSITY * inertia)
        in_link = frame.placement.actInv(shape.placement)  # geometry placements are in the joint's frame
        found[frame.name] = found.get(frame.name, pin.Inertia.Zero()) + in_link.act(solid)
    return found


def _inertial(link: ET.Element, inertia: pin.Inertia) -> None:
    el = ET.SubElement(link, "inertial")
    ET.SubElement(el, "origin", xyz=" ".join(repr(float(v)) for v in inertia.lever), rpy="0 0 0")
    ET.SubElement(el, "mass", value=repr(float(inertia.mass)))
    i = inertia.inertia
    names = {"ixx": i[0, 0], "ixy": i[0, 1], "ixz": i[0, 2], "iyy": i[1, 1], "iyz": i[1, 2], "izz": i[2, 2]}
    ET.SubElement(el, "inertia", {k: repr(float(v)) for k, v in names.items()})


def physical(mass: float, inertia: np.ndarray) -> bool:
    """A mass and inertia a rigid body can have: positive, positive definite, and no principal
    moment above the sum of the other two (the triangle inequality)."""
    moments = np.linalg.eigvalsh((inertia + inertia.T) / 2)
    return bool(mass > 0 and moments[0] > 0 and moments[0] + moments[1] >= moments[2] * (1 - 1e-9))


def _stated(link: ET.Element) -> tuple[float, np.ndarray] | None:
    """A link's stated mass and inertia (None: it states none)."""
    el = link.find("inertial")
    if el is None:
        return None
    mass = float(el.find("mass").get("value", 0.0)) if el.find("mass") is not None else 0.0
    a = {k: 0.0 for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    if el.find("inertia") is not None:
        a |= {k: float(v) for k, v in el.find("inertia").attrib.items() if k in a}
    inertia = np.array([[a["ixx"], a["ixy"], a["ixz"]], [a["ixy"], a["iyy"], a["iyz"]], [a["ixz"], a["iyz"], a["izz"]]])
    return mass, inertia


def with_inertias(urdf: str) -> str:
    """`urdf` with a physical <inertial> on every link (its meshes as paths pinocchio reads)."""
    root = ET.fromstring(urdf)
    stated = {link.get("name"): _stated(link) for link in root.findall("link")}
    missing = [
        link
        for link in root.findall("link")
        if stated[link.get("name")] is None or not physical(*stated[link.get("name")])
    ]
    if not missing:
        return urdf
    model = pin.buildModelFromXML(urdf)
    inertias = _link_inertias(model, urdf_geometry(model, urdf, pin.COLLISION))
    if any(link.get("name") not in inertias and link.find("visual") is not None for link in missing):
        visual = _link_inertias(model, urdf_geometry(model, urdf, pin.VISUAL))
        inertias = visual | inertias
    for link in missing:
        found = inertias.get(link.get("name"), pin.Inertia.FromSphere(FRAME_MASS, FRAME_RADIUS))
        mass = stated[link.get("name")][0] if stated[link.get("name")] is not None else 0.0
        if mass > 0:
            found = pin.Inertia(mass, found.lever, found.inertia * (mass / found.mass))
        if link.find("inertial") is not None:
            link.remove(link.find("inertial"))
        _inertial(link, found)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode")
