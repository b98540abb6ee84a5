"""The scene's bodies beyond the floor and the arm: the moved object and a task's obstacles.

What a task (:mod:`tooldesign_env.tasks`) puts into the world: the object the tool moves (the
box, or an upright cylinder) and fixed obstacles. :class:`~tooldesign_env.simulation.ToolSimulator`
builds them after the floor, the moved object first, so that a scene without obstacles has
the bodies, ids and order it always had.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from tooldesign_env.bullet import BulletWorld
from tooldesign_env.specs import SceneSpec
from tooldesign_env.tasks.base import OBJECT_SHAPES, Obstacle

__all__ = [
    "OBSTACLE_RGBA",
    "add_moved_object",
    "add_obstacles",
    "checked",
    "inertia_footprint",
]

#: Colour (r, g, b, a) of the fixed obstacles when rendered.
OBSTACLE_RGBA = (0.35, 0.35, 0.4, 1.0)


def checked(
    obstacles: Sequence[Obstacle], shape: str
) -> tuple[tuple[Obstacle, ...], str]:
    """``obstacles`` as a tuple and ``shape``, or an error saying what is wrong.

    Raises:
        TypeError: an obstacle is not an :class:`~tooldesign_env.tasks.Obstacle`.
        ValueError: ``shape`` is not one of :data:`~tooldesign_env.tasks.OBJECT_SHAPES`.
    """
    items = tuple(obstacles)
    if not all(isinstance(o, Obstacle) for o in items):
        raise TypeError(f"obstacles must be Obstacle specs, got {items!r}")
    if shape not in OBJECT_SHAPES:
        raise ValueError(f"object_shape must be one of {OBJECT_SHAPES}, got {shape!r}")
    return items, shape


def add_moved_object(
    world: BulletWorld,
    scene: SceneSpec,
    shape: str,
    mass: float,
    position: tuple[float, float],
    yaw: float,
) -> int:
    """Put the moved object at rest on the floor; its body id.

    Args:
        world: the world to build in.
        scene: its size (``box_size``; a cylinder's diameter is ``box_size[0]``) and friction.
        shape: ``"box"`` or ``"cylinder"`` (:data:`tooldesign_env.tasks.OBJECT_SHAPES`).
        mass: kg.
        position: centre (x, y) on the floor, m.
        yaw: rad.
    """
    where = (position[0], position[1], scene.box_size[2] / 2.0)
    if shape == "cylinder":
        return world.add_cylinder(
            radius=scene.box_size[0] / 2.0,
            height=scene.box_size[2],
            mass=mass,
            friction=scene.box_friction,
            position=where,
            yaw=yaw,
        )
    return world.add_box(
        size=scene.box_size, mass=mass, friction=scene.box_friction, position=where, yaw=yaw
    )


def add_obstacles(world: BulletWorld, obstacles: Sequence[Obstacle]) -> list[int]:
    """Put fixed obstacles (mass 0: PyBullet never moves them) on the floor; their body ids."""
    return [
        world.add_box(
            size=o.size,
            mass=0.0,
            friction=o.friction,
            position=(o.position[0], o.position[1], o.size[2] / 2.0),
            yaw=o.yaw,
            rgba=OBSTACLE_RGBA,
        )
        for o in obstacles
    ]


def inertia_footprint(scene: SceneSpec, shape: str) -> tuple[float, float, float]:
    """The box extents (m) whose turning inertia is the moved object's, for the contact mobility.

    The mobility takes a box's m (a^2 + b^2) / 12; a box sqrt(3) r wide has the cylinder's
    m r^2 / 2.
    """
    size = scene.box_size
    if shape != "cylinder":
        return size
    side = math.sqrt(3.0) * size[0] / 2.0
    return (side, side, size[2])
