"""What a task is: the scene's objects, the fixed plan, the goal range and the success radius.

A :class:`TaskDefinition` is the unit the task registry (:mod:`tooldesign_env.tasks.registry`)
holds and the env composes: ``ToolDesignEnv(task="hook")`` takes the task's scene, plan, goal
and fixed obstacles, and scores the tool with the same F as every other task. Pure data and
arithmetic: nothing here imports PyBullet.

Units are SI: metres and radians; positions are in the world frame, whose origin is the robot's
base on the floor, z up.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from tooldesign_env.specs import (
    FRICTION_MAX,
    WORKSPACE_HALF_WIDTH,
    WORKSPACE_HEIGHT,
    PlanSpec,
    SceneSpec,
    check_real,
    is_unordered,
)

__all__ = [
    "GOAL_CLEARANCE_BOX_WIDTHS",
    "HEIGHT_TOLERANCE",
    "MAX_TILT",
    "OBJECT_SHAPES",
    "ROBOT_BASE_CLEARANCE",
    "Obstacle",
    "TaskDefinition",
    "footprints_overlap",
]

#: The shapes of the object the tool moves: ``"box"`` (``SceneSpec.box_size``) or
#: ``"cylinder"`` (upright: diameter ``box_size[0]``, height ``box_size[2]``).
OBJECT_SHAPES = ("box", "cylinder")

#: Largest success radius accepted, m: past it "success" no longer says the box reached its goal.
TOLERANCE_MAX = 1.0

#: Default of :attr:`TaskDefinition.height_tolerance`, m: a box or puck standing on the floor
#: ends within a millimetre of its resting height; one lying on its side (a 0.1 x 0.1 x 0.2 m
#: box: 0.05 m) or tipped onto an obstacle (measured 0.067 to 0.084 m on the obstacle task's
#: curb) is 0.016 m or more below it.
HEIGHT_TOLERANCE = 0.01

#: Default of :attr:`TaskDefinition.max_tilt`, rad (10 degrees): a box standing on the floor
#: ends upright to a hundredth of a degree (at most 0.012 over the baselines of push, hook and
#: puck); one lying on its side is turned by 90 degrees, one tipped onto the obstacle task's
#: curb by 90 to 112 (docs/results/tasks/walls-output.txt).
MAX_TILT = math.radians(10.0)

#: Extents of an obstacle accepted, m (a 1 cm post to a 3 m wall).
OBSTACLE_SIZE_MIN = 0.01
OBSTACLE_SIZE_MAX = 3.0

#: Closest an obstacle's footprint may come to the robot's base axis (the world origin), m. The
#: Panda's base link (link0) reaches 0.158 m behind its axis, 0.099 m to either side and 0.076 m
#: in front (its collision box in PyBullet), and the arm's first links turn above it: an
#: obstacle nearer than 0.2 m stands in the base or against it.
ROBOT_BASE_CLEARANCE = 0.2

#: How far an obstacle's footprint is grown, in widths of the box (its larger floor extent),
#: before it is tested against the goal range: the box's centre can come no nearer an obstacle
#: than half the box's width, so a goal within that of an obstacle cannot be reached.
GOAL_CLEARANCE_BOX_WIDTHS = 0.5


def _floats(value: Any, length: int, label: str) -> tuple[float, ...]:
    """``value`` as ``length`` finite floats in order, or an error naming ``label``."""
    if (
        is_unordered(value)
        or isinstance(value, (str, bytes))
        or not isinstance(value, (Sequence, np.ndarray))
    ):
        raise TypeError(f"{label} must be {length} numbers in order, got {value!r}")
    if len(value) != length:
        raise ValueError(f"{label} must be {length} numbers, got {len(value)}: {value!r}")
    return tuple(check_real(v, label) for v in value)


def _corners(centre: tuple[float, float], size: tuple[float, float], yaw: float) -> np.ndarray:
    """The 4 corners (4, 2) in m of a rectangle of full extents ``size`` turned by ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    half = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]], dtype=float) * np.asarray(size) / 2.0
    rotation = np.array([[c, -s], [s, c]])
    corners: np.ndarray = np.asarray(centre, dtype=float) + half @ rotation.T
    return corners


def distance_to_footprint(
    point: tuple[float, float],
    footprint: tuple[tuple[float, float], tuple[float, float], float],
) -> float:
    """Distance (m) from ``point`` (x, y) to a rectangle ``(centre, (sx, sy), yaw)``; 0 inside."""
    (cx, cy), (sx, sy), yaw = footprint
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = point[0] - cx, point[1] - cy
    local = np.array([c * dx + s * dy, -s * dx + c * dy])
    return float(np.linalg.norm(np.maximum(np.abs(local) - np.array([sx, sy]) / 2.0, 0.0)))


def footprints_overlap(
    a: tuple[tuple[float, float], tuple[float, float], float],
    b: tuple[tuple[float, float], tuple[float, float], float],
    *,
    clearance: float = 0.0,
) -> bool:
    """Whether two rectangles on the floor overlap or touch, or come closer than ``clearance`` (m).

    Each is ``(centre (x, y), extents (sx, sy), yaw)`` in m and rad. Separating-axis test on
    the four edge normals; ``clearance`` grows both rectangles by half of it on every side.
    Rectangles that touch (a gap of exactly 0 along some axis) count as overlapping: a box
    starting against a wall is already in contact with it, which is not the free start a task's
    plan assumes.
    """
    grown = [
        (centre, (size[0] + clearance, size[1] + clearance), yaw) for centre, size, yaw in (a, b)
    ]
    pa, pb = (_corners(*r) for r in grown)
    for yaw in (grown[0][2], grown[1][2]):
        for axis in ((math.cos(yaw), math.sin(yaw)), (-math.sin(yaw), math.cos(yaw))):
            da, db = pa @ np.asarray(axis), pb @ np.asarray(axis)
            if da.max() < db.min() or db.max() < da.min():  # a gap: apart; none: touching
                return False
    return True


@dataclass(frozen=True, kw_only=True)
class Obstacle:
    """A fixed box standing on the floor (a post or a wall): it moves for nothing.

    Attributes:
        name: what the docs and errors call it, e.g. ``"post"``.
        position: centre of its footprint (x, y), m.
        size: full extents (x, y, z), m; z is its height above the floor.
        yaw: turn about z, rad.
        friction: lateral friction coefficient (PyBullet multiplies the pair's).

    Limits (a ValueError names the field otherwise): ``position`` inside the workspace (x, y
    within +-2.5 m), each extent 0.01 to 3 m, ``yaw`` within +-2 pi rad, ``friction`` 0 to 10.
    """

    name: str
    position: tuple[float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0
    friction: float = 0.5

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"Obstacle.name must be a non-empty string, got {self.name!r}")
        position = _floats(self.position, 2, "Obstacle.position")
        size = _floats(self.size, 3, "Obstacle.size")
        if not all(abs(v) <= WORKSPACE_HALF_WIDTH for v in position):
            raise ValueError(
                f"Obstacle.position must be inside the workspace: x, y in "
                f"[-{WORKSPACE_HALF_WIDTH:g}, {WORKSPACE_HALF_WIDTH:g}] m, got {self.position!r}"
            )
        if not all(OBSTACLE_SIZE_MIN <= v <= OBSTACLE_SIZE_MAX for v in size):
            raise ValueError(
                f"Obstacle.size must be three extents from {OBSTACLE_SIZE_MIN:g} to "
                f"{OBSTACLE_SIZE_MAX:g} m, got {self.size!r}"
            )
        yaw = check_real(self.yaw, "Obstacle.yaw")
        if abs(yaw) > 2.0 * math.pi:
            raise ValueError(f"Obstacle.yaw must be within +-2 pi rad, got {self.yaw!r}")
        friction = check_real(self.friction, "Obstacle.friction")
        if not 0.0 <= friction <= FRICTION_MAX:
            raise ValueError(
                f"Obstacle.friction must be a number in [0, {FRICTION_MAX:g}], got "
                f"{self.friction!r}"
            )
        object.__setattr__(self, "position", position)
        object.__setattr__(self, "size", size)
        object.__setattr__(self, "yaw", yaw)
        object.__setattr__(self, "friction", friction)

    def footprint(self) -> tuple[tuple[float, float], tuple[float, float], float]:
        """``(centre, (sx, sy), yaw)`` on the floor, for :func:`footprints_overlap`."""
        return (self.position[0], self.position[1]), (self.size[0], self.size[1]), self.yaw


@dataclass(frozen=True, kw_only=True)
class TaskDefinition:
    """A task: what is in the scene, how the arm moves, where the box should go, what succeeds.

    Every task is scored with the same F (goal error and control confidence, ``ObjectiveSpec``),
    so optimizers, the harness and the RL ids work with any of them unchanged.

    Attributes:
        name: the registry's name, e.g. ``"hook"``; ``tooldesign design --task NAME``.
        title: one line saying what the tool must do.
        scene: the physical world: the box's start, its size, friction (``SceneSpec``).
        plan: the fixed plan pi_0 of this task (``PlanSpec``).
        plan_reason: why this plan: what the arm's motion lets a tool do here.
        goal: the default goal X^g (x, y, z), m.
        goal_low: the low corner of the goal range (x, y, z), m: where goals are drawn
            (``randomize_goal=True``) and, unless ``accepts_any_goal``, the only goals taken.
        goal_high: its high corner, m.
        tolerance: success radius, m: an episode succeeds when the box ends within it of the
            goal (``info["success"]``) and stands on the floor (``max_tilt`` and
            ``height_tolerance``).
        max_tilt: the largest angle of the box's up axis from the vertical at the end, rad,
            that still counts as standing: a box that ends lying on its side, tipped onto an
            obstacle or leaning on one is not at the goal, wherever its centre is. Default
            :data:`MAX_TILT` (10 degrees).
        height_tolerance: the largest distance, m, of the box centre's final height from its
            resting height (half the box's height, where it starts) that still counts as
            standing on the floor (not on an obstacle, nor lying). Default
            :data:`HEIGHT_TOLERANCE`.
        obstacles: fixed bodies on the floor (:class:`Obstacle`).
        object_shape: the moved object's shape, one of :data:`OBJECT_SHAPES`.
        accepts_any_goal: take a goal anywhere in the workspace (the paper's push task, as
            ``ToolDesign-v0`` always did), not only in the goal range.

    Raises:
        ValueError: a field out of its range, a default goal outside the goal range, an
            obstacle overlapping the box's start, an obstacle that covers part of the goal
            range once grown by half the box's width (:data:`GOAL_CLEARANCE_BOX_WIDTHS`: no box
            can end at those goals), an obstacle nearer than :data:`ROBOT_BASE_CLEARANCE`
            (0.2 m) to the robot's base axis, or a cylinder whose ``box_size[0]`` (its
            diameter) differs from ``box_size[1]``.
    """

    name: str
    title: str
    scene: SceneSpec = field(default_factory=SceneSpec)
    plan: PlanSpec = field(default_factory=PlanSpec)
    plan_reason: str = ""
    goal: tuple[float, float, float]
    goal_low: tuple[float, float, float]
    goal_high: tuple[float, float, float]
    tolerance: float
    max_tilt: float = MAX_TILT
    height_tolerance: float = HEIGHT_TOLERANCE
    obstacles: tuple[Obstacle, ...] = ()
    object_shape: str = "box"
    accepts_any_goal: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip() or " " in self.name:
            raise ValueError(
                f"TaskDefinition.name must be a non-empty word (no spaces), got {self.name!r}"
            )
        for label, spec, kind in (
            ("scene", self.scene, SceneSpec),
            ("plan", self.plan, PlanSpec),
        ):
            if not isinstance(spec, kind):
                raise TypeError(
                    f"TaskDefinition.{label} must be a {kind.__name__}, got "
                    f"{type(spec).__name__} {spec!r}"
                )
        for name in ("goal", "goal_low", "goal_high"):
            point = _floats(getattr(self, name), 3, f"TaskDefinition.{name}")
            object.__setattr__(self, name, point)
        low, high = np.asarray(self.goal_low), np.asarray(self.goal_high)
        limit = np.array([WORKSPACE_HALF_WIDTH, WORKSPACE_HALF_WIDTH, WORKSPACE_HEIGHT])
        if np.any(low > high) or np.any(high > limit) or np.any(low < limit * [-1, -1, 0]):
            raise ValueError(
                f"the {self.name} task's goal range must have low <= high per axis, inside the "
                f"workspace, got low {list(self.goal_low)}, high {list(self.goal_high)}"
            )
        for name in ("tolerance", "height_tolerance"):
            metres = check_real(getattr(self, name), f"TaskDefinition.{name}")
            if not 0.0 < metres <= TOLERANCE_MAX:
                raise ValueError(
                    f"TaskDefinition.{name} must be a number of metres in "
                    f"(0, {TOLERANCE_MAX:g}], got {getattr(self, name)!r}"
                )
            object.__setattr__(self, name, metres)
        max_tilt = check_real(self.max_tilt, "TaskDefinition.max_tilt")
        if not 0.0 < max_tilt <= math.pi / 2:
            raise ValueError(
                f"TaskDefinition.max_tilt must be an angle in (0, pi/2] rad, got {self.max_tilt!r}"
            )
        object.__setattr__(self, "max_tilt", max_tilt)
        obstacles = tuple(self.obstacles)
        for item in obstacles:
            if not isinstance(item, Obstacle):
                raise TypeError(
                    f"TaskDefinition.obstacles must hold Obstacle specs, got "
                    f"{type(item).__name__} {item!r}"
                )
        object.__setattr__(self, "obstacles", obstacles)
        if self.object_shape not in OBJECT_SHAPES:
            raise ValueError(
                f"TaskDefinition.object_shape must be one of {OBJECT_SHAPES}, got "
                f"{self.object_shape!r}"
            )
        object.__setattr__(self, "accepts_any_goal", bool(self.accepts_any_goal))
        self.check_goal(self.goal, "TaskDefinition.goal")
        self.check_scene(self.scene)
        self._check_obstacles_clear()

    # ------------------------------------------------------------------ checks
    def goal_range_text(self) -> str:
        """The goal range in words, for messages and docs."""
        (x0, y0, z0), (x1, y1, z1) = self.goal_low, self.goal_high
        return f"x in [{x0:g}, {x1:g}], y in [{y0:g}, {y1:g}], z in [{z0:g}, {z1:g}] m"

    def check_goal(self, goal: Any, label: str = "goal") -> tuple[float, float, float]:
        """``goal`` as (x, y, z) if this task takes it, else a one-line error.

        A task that ``accepts_any_goal`` takes every goal of the workspace (the env checks
        that); the others only goals in their goal range, where the box can be brought.

        Raises:
            TypeError: not 3 numbers.
            ValueError: outside the goal range.
        """
        x, y, z = _floats(goal, 3, label)
        if not self.accepts_any_goal:
            inside = all(
                lo - 1e-12 <= v <= hi + 1e-12
                for v, lo, hi in zip((x, y, z), self.goal_low, self.goal_high, strict=True)
            )
            if not inside:
                raise ValueError(
                    f"{label} {[x, y, z]} is outside the {self.name} task's goal range "
                    f"({self.goal_range_text()})"
                )
        return x, y, z

    def _check_obstacles_clear(self) -> None:
        """Refuse an obstacle on the robot's base or over goals of the goal range (one line)."""
        (x0, y0, _), (x1, y1, _) = self.goal_low, self.goal_high
        goals = (((x0 + x1) / 2.0, (y0 + y1) / 2.0), (x1 - x0, y1 - y0), 0.0)
        grow = GOAL_CLEARANCE_BOX_WIDTHS * max(self.scene.box_size[0], self.scene.box_size[1])
        for index, obstacle in enumerate(self.obstacles):
            where = (
                f"obstacle {index} ({obstacle.name} at "
                f"{[round(v, 3) for v in obstacle.position]}, {obstacle.size[0]:g} x "
                f"{obstacle.size[1]:g} m)"
            )
            base = distance_to_footprint((0.0, 0.0), obstacle.footprint())
            if base < ROBOT_BASE_CLEARANCE:
                raise ValueError(
                    f"the {self.name} task's {where} comes {base:.3g} m from the robot's base "
                    f"axis (0, 0), nearer than ROBOT_BASE_CLEARANCE = {ROBOT_BASE_CLEARANCE:g} m "
                    "(the arm stands there); move the obstacle"
                )
            centre, size, yaw = obstacle.footprint()
            grown = (centre, (size[0] + 2.0 * grow, size[1] + 2.0 * grow), yaw)
            if footprints_overlap(grown, goals):
                raise ValueError(
                    f"the {self.name} task's {where}, grown by half the box's width "
                    f"({grow:g} m), covers part of its goal range ({self.goal_range_text()}): "
                    "no box can end at those goals; move the obstacle or shrink the goal range"
                )

    def check_scene(self, scene: SceneSpec) -> None:
        """Refuse a scene the task's object cannot start in.

        Raises:
            ValueError: an obstacle overlaps the box's footprint at the start, or the object
                is a cylinder (``object_shape="cylinder"``, diameter ``box_size[0]``) whose
                ``box_size[1]`` differs from ``box_size[0]`` (it would be ignored).
        """
        if self.object_shape == "cylinder" and not math.isclose(
            scene.box_size[0], scene.box_size[1], rel_tol=1e-9, abs_tol=1e-12
        ):
            raise ValueError(
                f"the {self.name} task's object is an upright cylinder of diameter box_size[0], "
                f"so box_size[0] and box_size[1] must be equal, got box_size "
                f"{list(scene.box_size)}"
            )
        box = (
            (scene.box_position[0], scene.box_position[1]),
            (scene.box_size[0], scene.box_size[1]),
            scene.box_yaw,
        )
        for index, obstacle in enumerate(self.obstacles):
            if footprints_overlap(box, obstacle.footprint()):
                raise ValueError(
                    f"the {self.name} task's obstacle {index} ({obstacle.name} at "
                    f"{[round(v, 3) for v in obstacle.position]}, {obstacle.size[0]:g} x "
                    f"{obstacle.size[1]:g} m) overlaps the box's start "
                    f"{[round(v, 3) for v in scene.box_position]}; move the box "
                    "(scene box_position) or the obstacle"
                )

    def succeeded(
        self,
        final_distance: float,
        final_height: float | None,
        scene: SceneSpec | None = None,
        *,
        final_tilt: float | None = None,
    ) -> bool:
        """Whether a box that ended so far from the goal, this high and this tilted, is at it.

        Args:
            final_distance: the box centre's final distance to the goal, m.
            final_height: the box centre's final height above the floor, m; None does not check
                it.
            scene: the scene whose box it is (default: the task's): its resting height is half
                its height.
            final_tilt: the final angle of the box's up axis from the vertical, rad; None
                checks the height alone.

        Returns:
            ``final_distance <= tolerance``, the height (if given) within
            ``height_tolerance`` of the resting height and the tilt (if given) at most
            ``max_tilt``.
        """
        return bool(
            final_distance <= self.tolerance
            and (
                final_height is None
                or abs(final_height - self.box_start(scene)[2]) <= self.height_tolerance
            )
            and (final_tilt is None or final_tilt <= self.max_tilt)
        )

    def sample_goal(self, rng: np.random.Generator) -> np.ndarray:
        """A goal (3,) m drawn uniformly from the goal range with ``rng``."""
        return rng.uniform(self.goal_low, self.goal_high)

    def box_start(self, scene: SceneSpec | None = None) -> np.ndarray:
        """The box centre's start (x, y, z), m, in ``scene`` (default: the task's)."""
        scene = self.scene if scene is None else scene
        return np.array([*scene.box_position, scene.box_size[2] / 2.0])
