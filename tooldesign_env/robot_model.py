"""The robot model: the Panda's URDF with a tool attached, and the merged hand's mass properties.

Pure text and arithmetic on the URDF that ``pybullet_data`` ships, plus two caches: the merged
hand's URDF and masses (once per process) and PyBullet's own dynamics of the hand's links (kept in
the plan cache's folder, :func:`tooldesign_env.plan.cache_dir`). Reading those dynamics takes a
physics server, which this module asks :class:`~tooldesign_env.bullet.BulletWorld` for: only
``bullet.py`` imports PyBullet. The lean copies of the arm's collision meshes, the other asset
cache, are :mod:`tooldesign_env.lean_meshes`.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import platform
import re
from collections.abc import Mapping, Sequence

import numpy as np

from tooldesign_env.bullet import (
    EE_LINK,
    PANDA_DIR,
    TOOL_LINK,
    BulletWorld,
    engine_version,
    rotation_matrices,
)
from tooldesign_env.geometry import ToolGeometry, tool_link_xml
from tooldesign_env.plan import cache_key, load_knots, source_digest, store_knots
from tooldesign_env.rigid_groups import (
    Inertial,
    combine_inertials,
    fixed_subtree,
    merge_fixed_links,
    parts_in_root,
    principal_axes,
)

__all__ = [
    "HAND_LINKS",
    "HAND_ROOT",
    "merged_hand_inertia",
    "panda_urdf_with_tool",
    "principal_inertia",
    "robot_model_digest",
    "tool_link_with_principal_axes",
]


def panda_urdf_with_tool(
    tool_link_xml: str | None,
    *,
    visuals: bool,
    meshes: Mapping[str, str] | None = None,
    merge_hand: bool = False,
) -> str:
    """The Panda URDF from ``pybullet_data`` with a tool rigidly attached to the grasp target.

    The fingers become fixed joints: they hold nothing (the tool is a link of the arm), and a
    7-degree-of-freedom body lets the inverse dynamics run on exactly the 7 arm joints. The tool
    link hangs rotated by Rx(pi) from ``panda_grasptarget`` so that its z axis points up while the
    gripper points down.

    Args:
        tool_link_xml: a ``<link name="tool">`` element, or None for the arm alone.
        visuals: keep the visual shapes, the Panda's meshes and the tool's (needed to render;
            slower to load).
        meshes: mesh files to load in place of the Panda's, {original path: replacement path}
            (:func:`lean_collision_meshes`).
        merge_hand: fold the links that no joint moves below the last arm joint (the flange
            ``panda_link8``, the hand and the fingers) into ``panda_link7``
            (``SceneSpec.merge_fixed_links``): load it with :func:`merged_hand_inertia` given
            to :meth:`BulletWorld.load_robot`.

    Returns:
        The URDF text, with mesh paths made absolute.
    """
    if merge_hand:
        text = _merged_panda(visuals, tuple(sorted((meshes or {}).items())))[0]
        meshes = None  # already in place
    else:
        text = _panda_urdf(visuals)
    if tool_link_xml is not None:
        if not visuals:
            tool_link_xml = _without_visuals(tool_link_xml)
        joint = (
            f'<joint name="tool_joint" type="fixed"><parent link="{EE_LINK}"/>'
            f'<child link="{TOOL_LINK}"/><origin rpy="3.141592653589793 0 0" xyz="0 0 0"/>'
            "</joint>"
        )
        text = text.replace("</robot>", f"{tool_link_xml}\n{joint}\n</robot>")
    return _with_collision_meshes(text, tuple((meshes or {}).items()))


def _with_collision_meshes(text: str, meshes: Sequence[tuple[str, str]]) -> str:
    """``text`` with each (original, replacement) mesh path swapped inside ``<collision>``.

    Only there: link0's and link7's visuals load the same files, and the lean copies are no
    longer meshes to draw (:func:`lean_collision_mesh`).
    """
    if not meshes:
        return text

    def swap(block: re.Match[str]) -> str:
        part = block.group(0)
        for original, replacement in meshes:
            part = part.replace(f'"{original}"', f'"{replacement}"')
        return part

    return re.sub(r"<collision\b.*?</collision>", swap, text, flags=re.S)


#: The links that :func:`panda_urdf_with_tool` folds into ``HAND_ROOT`` with ``merge_hand``:
#: the grasp target stays a link (the rollout reads its pose), as does the tool (the contact
#: estimator reads its contacts, its friction and its shape's contact threshold are its own).
HAND_ROOT = "panda_link7"
HAND_LINKS = ("panda_link8", "panda_hand", "panda_leftfinger", "panda_rightfinger")


def merged_hand_inertia(
    *, visuals: bool, meshes: Mapping[str, str] | None = None
) -> dict[str, tuple[float, tuple[float, float, float]]]:
    """The merged hand's mass properties, for :meth:`BulletWorld.load_robot`.

    Returns:
        {``HAND_ROOT``: (mass kg, principal moments kg m^2)}, its ``link_inertias`` for the
        URDF of ``panda_urdf_with_tool(..., merge_hand=True)``.
    """
    _, mass, moments = _merged_panda(visuals, tuple(sorted((meshes or {}).items())))
    return {HAND_ROOT: (mass, moments)}


@functools.cache
def _merged_panda(
    visuals: bool, meshes: tuple[tuple[str, str], ...]
) -> tuple[str, float, tuple[float, float, float]]:
    """The Panda's URDF with ``HAND_LINKS`` folded into ``HAND_ROOT``; its mass and moments.

    The parts' mass properties are PyBullet's own: it takes each link's mass and inertial
    frame from the URDF but its principal moments from the bounding box of its collision
    shapes, so they are read off the unmerged model, loaded once in a server of its own (so
    that no world sees an extra body), and summed exactly (:mod:`tooldesign_env.rigid_groups`).
    """
    text = _with_collision_meshes(_panda_urdf(visuals), meshes)
    parts = {}
    for name, row in zip((HAND_ROOT, *HAND_LINKS), _hand_dynamics(text), strict=True):
        mass, diagonal, center, orientation = row[0], row[1:4], row[4:7], row[7:11]
        turn = rotation_matrices(orientation)
        parts[name] = Inertial(float(mass), center.copy(), turn @ np.diag(diagonal) @ turn.T)
    frames = fixed_subtree(text, HAND_ROOT)
    whole = combine_inertials(parts_in_root(frames, parts))
    moments, _ = principal_axes(whole.tensor)
    return merge_fixed_links(text, HAND_ROOT, HAND_LINKS, whole), whole.mass, moments


@functools.cache
def _panda_urdf(visuals: bool) -> str:
    """The Panda's URDF as :func:`panda_urdf_with_tool` starts from it (read once a process)."""
    with open(os.path.join(PANDA_DIR, "panda.urdf"), encoding="utf-8") as f:
        text = f.read()
    text = text.replace("package://meshes/", os.path.join(PANDA_DIR, "meshes") + "/")
    text = re.sub(r'(<joint name="panda_finger_joint\d" )type="prismatic"', r'\1type="fixed"', text)
    text = re.sub(r"\s*<mimic[^>]*/>", "", text)
    return text if visuals else _without_visuals(text)


def _without_visuals(text: str) -> str:
    # The tool's too: PyBullet tessellates a capsule's visual into a convex hull at load, which
    # cost a round tool about 9 ms of a 37 ms build. Physics never reads visuals.
    return re.sub(r"<visual\b[^>]*>.*?</visual>", "", text, flags=re.S)


#: Bumped whenever :func:`_hand_dynamics` stores something else.
HAND_DYNAMICS_FORMAT = 1


def _hand_dynamics(text: str) -> np.ndarray:
    """PyBullet's dynamics of ``HAND_ROOT`` and ``HAND_LINKS`` in the robot of URDF ``text``.

    One row per link: mass, principal moments (3), inertial frame's position (3) and
    orientation (4), as ``getDynamicsInfo`` gives them. Reading them means loading the robot in
    a server of its own (about 30 ms, once per process), so they are kept in the plan cache's
    folder (:func:`tooldesign_env.plan.cache_dir`), keyed by the URDF text (whose mesh paths
    name the lean copies by their content), PyBullet's version and the machine's architecture.
    The file holds the float64 values exactly, so a process that reads it builds the same
    merged hand, bit for bit, as one that loaded the robot.
    """
    key = cache_key(
        {
            "hand_dynamics": HAND_DYNAMICS_FORMAT,
            # How the robot is loaded (flags, inertia) and read.
            "source": [source_digest("tooldesign_env.bullet"), source_digest(__name__)],
            "urdf": hashlib.sha256(text.encode("utf-8")).hexdigest(),
            "links": [HAND_ROOT, *HAND_LINKS],
            "pybullet": engine_version(),
            "machine": platform.machine(),
        }
    )
    shape = (1 + len(HAND_LINKS), 11)
    stored = load_knots(key, shape)
    if stored is not None:
        return stored
    world = BulletWorld(renderer=False)
    try:
        robot = world.load_robot(text)
        links = world.indices(robot.body)
        rows = []
        for name in (HAND_ROOT, *HAND_LINKS):
            info = world.dynamics_info(robot.body, links[name])
            rows.append([info[0], *info[2], *info[3], *info[4]])
    finally:
        world.close()
    dynamics = np.asarray(rows, dtype=np.float64)
    store_knots(key, dynamics)
    return dynamics


@functools.cache
def robot_model_digest() -> str:
    """SHA-256 of the arm's URDF as loaded for inverse kinematics (no tool, no visuals).

    The folder of ``pybullet_data`` is left out, so the same files give the same digest in
    any environment; any change of the kinematics (joint origins, axes, limits) changes it.
    """
    text = panda_urdf_with_tool(None, visuals=False).replace(PANDA_DIR, "<panda>")
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def principal_inertia(inertia: np.ndarray) -> tuple[np.ndarray, float]:
    """Principal moments (3,) kg m^2 and the yaw (rad) of the principal axes of a planar body.

    PyBullet takes a diagonal inertia in an inertial frame, so the tool's tensor is rotated into
    its principal axes. The tool is symmetric about its z = 0 plane (Ixz = Iyz = 0), so the
    principal frame differs from the tool frame by a rotation about z only.
    """
    ixx, iyy, ixy = inertia[0, 0], inertia[1, 1], inertia[0, 1]
    yaw = 0.5 * math.atan2(2.0 * ixy, ixx - iyy)
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    diag = np.diag(rot.T @ inertia @ rot).copy()
    return diag, yaw


def tool_link_with_principal_axes(geometry: ToolGeometry) -> tuple[str, np.ndarray]:
    """The tool's URDF link with its inertial frame turned to the principal axes.

    Returns:
        (the ``<link name="tool">`` element, its principal moments (3,) kg m^2), for
        :func:`panda_urdf_with_tool` and :meth:`~tooldesign_env.bullet.BulletWorld.load_robot`.
    """
    diag, yaw = principal_inertia(np.asarray(geometry.inertia))
    xml = tool_link_xml(geometry, "tool")
    start = xml.index("<inertial>")
    end = xml.index("</inertial>") + len("</inertial>")
    com = " ".join(repr(float(v)) for v in geometry.center_of_mass)
    # Python floats: NumPy 2 writes a np.float64 as "np.float64(...)", which is not a URDF number.
    ixx, iyy, izz = (float(v) for v in diag)
    inertial = (
        f'<inertial><origin xyz="{com}" rpy="0 0 {yaw!r}"/><mass value="{geometry.mass!r}"/>'
        f'<inertia ixx="{ixx!r}" ixy="0" ixz="0" iyy="{iyy!r}" iyz="0" izz="{izz!r}"/>'
        "</inertial>"
    )
    return xml[:start] + inertial + xml[end:], diag


#: The arm joints' indices in PyBullet's state vectors: (q indices, u indices).
_JointSlots = tuple[tuple[int, ...], tuple[int, ...]]
