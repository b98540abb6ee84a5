"""Links held together by fixed joints, merged into one link of a URDF.

The Panda carries, below its last revolute joint, a chain of links that no joint moves: the
flange (``panda_link8``), the hand, the two fingers (fixed here, see
:func:`tooldesign_env.bullet.panda_urdf_with_tool`), the grasp target and the tool. PyBullet
makes each of them a link of the multibody, and its articulated-body dynamics pay for every
link on every physics step. Merged into ``panda_link7`` they are one rigid body, as they are in
fact: the same shapes in the same places, the same mass, centre of mass and inertia tensor.

PyBullet can merge them itself (``URDF_MERGE_FIXED_LINKS``), but it then computes the merged
link's inertia from the bounding box of all its shapes: M(q) moved by 3-4 % on the designs
tried. Here the merge is written into the URDF instead, and the merged inertia is the exact sum
of the parts' (parallel-axis theorem), so that only floating-point rounding separates the two
models (:func:`merge_fixed_links`).

Nothing here imports PyBullet: the parts' inertias are inputs, read by the caller from the
unmerged model as PyBullet builds it (:meth:`tooldesign_env.bullet.BulletWorld.load_robot`).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "Inertial",
    "combine_inertials",
    "fixed_subtree",
    "matrix_rpy",
    "merge_fixed_links",
    "principal_axes",
    "rpy_matrix",
]


@dataclass(frozen=True)
class Inertial:
    """A rigid part's mass properties, in some frame F.

    Attributes:
        mass: kg.
        center: (3,) centre of mass in F, m.
        tensor: (3, 3) inertia tensor about the centre of mass, axes of F, kg m^2.
    """

    mass: float
    center: np.ndarray
    tensor: np.ndarray

    def moved(self, rotation: np.ndarray, translation: np.ndarray) -> Inertial:
        """The same part in frame G, where a point p of F is at ``rotation @ p + translation``."""
        return Inertial(
            self.mass,
            rotation @ self.center + translation,
            rotation @ self.tensor @ rotation.T,
        )


def combine_inertials(parts: Sequence[Inertial]) -> Inertial:
    """The mass properties of rigidly joined parts, all given in one frame.

    Raises:
        ValueError: if there are no parts or their total mass is not > 0.
    """
    if not parts:
        raise ValueError("combine_inertials needs at least one part, got none")
    mass = math.fsum(p.mass for p in parts)
    if not (math.isfinite(mass) and mass > 0):
        raise ValueError(f"the parts' total mass must be a finite number > 0 kg, got {mass!r}")
    center = np.sum([p.mass * np.asarray(p.center, dtype=float) for p in parts], axis=0) / mass
    tensor = np.zeros((3, 3))
    for p in parts:
        d = p.center - center
        tensor += p.tensor + p.mass * (float(d @ d) * np.eye(3) - np.outer(d, d))
    return Inertial(mass, center, tensor)


def rpy_matrix(rpy: Sequence[float]) -> np.ndarray:
    """URDF's rotation of ``rpy`` (roll, pitch, yaw about fixed x, y, z): Rz(y) Ry(p) Rx(r)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr = math.cos(r), math.sin(r)
    cp, sp = math.cos(p), math.sin(p)
    cy, sy = math.cos(y), math.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_rpy(rotation: np.ndarray) -> tuple[float, float, float]:
    """The URDF (roll, pitch, yaw) of a rotation matrix (the inverse of :func:`rpy_matrix`)."""
    m = np.asarray(rotation, dtype=float)
    # cos(pitch) from the first column, not asin of one entry: accurate near +-pi/2 as well.
    cp = math.hypot(m[0, 0], m[1, 0])
    pitch = math.atan2(-m[2, 0], cp)
    if cp > 1e-12:
        roll = math.atan2(m[2, 1], m[2, 2])
        yaw = math.atan2(m[1, 0], m[0, 0])
    else:  # gimbal lock: only roll - yaw (or roll + yaw) is defined; take yaw = 0
        roll = math.atan2(-m[1, 2], m[1, 1])
        yaw = 0.0
    return roll, pitch, yaw


def _origin(element: ET.Element | None) -> tuple[np.ndarray, np.ndarray]:
    """(rotation, translation) of an ``<origin>`` element (identity if absent)."""
    if element is None:
        return np.eye(3), np.zeros(3)
    xyz = [float(v) for v in element.get("xyz", "0 0 0").split()]
    rpy = [float(v) for v in element.get("rpy", "0 0 0").split()]
    return rpy_matrix(rpy), np.array(xyz, dtype=float)


def _set_origin(parent: ET.Element, rotation: np.ndarray, translation: np.ndarray) -> None:
    origin = parent.find("origin")
    if origin is None:
        origin = ET.Element("origin")
        parent.insert(0, origin)
    origin.set("xyz", " ".join(repr(float(v)) for v in translation))
    origin.set("rpy", " ".join(repr(float(v)) for v in matrix_rpy(rotation)))


def fixed_subtree(urdf_text: str, root: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Every link that fixed joints hold to ``root``, with its frame in ``root``'s frame.

    Returns:
        {link name: (rotation, translation)}, ``root`` itself included (identity): a point p of
        the link is at ``rotation @ p + translation`` in ``root``'s frame.

    Raises:
        ValueError: if ``root`` is not a link of the URDF.
    """
    robot = ET.fromstring(urdf_text)
    if not any(link.get("name") == root for link in robot.iter("link")):
        raise ValueError(f"root must be a link of the URDF, got {root!r}")
    frames = {root: (np.eye(3), np.zeros(3))}
    joints = [j for j in robot.iter("joint") if j.get("type") == "fixed"]
    grew = True
    while grew:
        grew = False
        for joint in joints:
            parent = joint.find("parent").get("link")  # type: ignore[union-attr]
            child = joint.find("child").get("link")  # type: ignore[union-attr]
            if parent in frames and child is not None and child not in frames:
                rotation, translation = _origin(joint.find("origin"))
                parent_rotation, parent_translation = frames[parent]
                frames[child] = (
                    parent_rotation @ rotation,
                    parent_rotation @ translation + parent_translation,
                )
                grew = True
    return frames


def merge_fixed_links(
    urdf_text: str,
    root: str,
    merged: Sequence[str],
    inertial: Inertial,
) -> str:
    """The URDF with the links ``merged`` folded into ``root``.

    Each merged link's collision (and visual) shapes move into ``root`` with their origins
    carried into ``root``'s frame; its joint goes; a link that hangs from a merged link by a
    fixed joint and is not merged itself (the grasp target, say) hangs from ``root`` instead,
    at the same place. ``root``'s ``<inertial>`` becomes ``inertial`` (given in ``root``'s
    frame), written in its principal axes: PyBullet reads a link's inertial frame from the URDF,
    and the caller sets the principal moments after loading (PyBullet would otherwise compute
    them from the shapes' bounding box).

    Args:
        urdf_text: the URDF.
        root: the link that stays.
        merged: links held to ``root`` by fixed joints (:func:`fixed_subtree`).
        inertial: the mass properties of ``root`` and ``merged`` together, in ``root``'s frame
            (:func:`combine_inertials`).

    Returns:
        The new URDF text.

    Raises:
        ValueError: if a link of ``merged`` is not held to ``root`` by fixed joints.
    """
    frames = fixed_subtree(urdf_text, root)
    strays = [name for name in merged if name not in frames or name == root]
    if strays:
        raise ValueError(
            f"merged must name links held to {root!r} by fixed joints (not {root!r} itself), "
            f"got {strays!r}; allowed: {sorted(set(frames) - {root})!r}"
        )
    robot = ET.fromstring(urdf_text)
    links = {link.get("name"): link for link in robot.findall("link")}
    target = links[root]
    gone = set(merged)
    for name in merged:
        link = links[name]
        rotation, translation = frames[name]
        for kind in ("collision", "visual"):
            for shape in link.findall(kind):
                r, t = _origin(shape.find("origin"))
                _set_origin(shape, rotation @ r, rotation @ t + translation)
                target.append(shape)
        robot.remove(link)
    for joint in robot.findall("joint"):
        parent = joint.find("parent")
        child = joint.find("child")
        assert parent is not None and child is not None
        if child.get("link") in gone:
            robot.remove(joint)
        elif parent.get("link") in gone:
            # Re-hang it from root, at the same place.
            rotation, translation = frames[str(parent.get("link"))]
            r, t = _origin(joint.find("origin"))
            _set_origin(joint, rotation @ r, rotation @ t + translation)
            parent.set("link", root)
    for old in target.findall("inertial"):
        target.remove(old)
    moments, axes = principal_axes(inertial.tensor)
    element = ET.Element("inertial")
    _set_origin(element, axes, inertial.center)
    ET.SubElement(element, "mass", value=repr(float(inertial.mass)))
    ixx, iyy, izz = (repr(float(v)) for v in moments)
    ET.SubElement(element, "inertia", ixx=ixx, ixy="0", ixz="0", iyy=iyy, iyz="0", izz=izz)
    target.insert(0, element)
    return ET.tostring(robot, encoding="unicode")


def principal_axes(tensor: np.ndarray) -> tuple[tuple[float, float, float], np.ndarray]:
    """The principal moments (ascending) of an inertia tensor, and their axes.

    The axes are the columns of a rotation (determinant +1, not a reflection).
    """
    moments, axes = np.linalg.eigh(np.asarray(tensor, dtype=float))
    if np.linalg.det(axes) < 0:
        axes[:, 0] = -axes[:, 0]
    return (float(moments[0]), float(moments[1]), float(moments[2])), axes


def parts_in_root(
    frames: Mapping[str, tuple[np.ndarray, np.ndarray]], parts: Mapping[str, Inertial]
) -> list[Inertial]:
    """Each part's :class:`Inertial`, given in its own link's frame, carried into the root's."""
    return [parts[name].moved(*frames[name]) for name in parts]
