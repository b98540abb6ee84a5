"""``obstacle``: PROVISIONAL (placement measured next)."""

from __future__ import annotations

import math

from tooldesign_env.specs import PlanSpec, SceneSpec
from tooldesign_env.tasks.base import Obstacle, TaskDefinition

__all__ = ["OBSTACLE"]

OBSTACLE = TaskDefinition(
    name="obstacle",
    title="bring the box to the goal past a fixed post",
    scene=SceneSpec(),
    plan=PlanSpec(),
    plan_reason="",
    obstacles=(
        Obstacle(
            name="post",
            position=(1.6 * math.cos(math.radians(55.0)), 1.6 * math.sin(math.radians(55.0))),
            size=(0.1, 0.1, 0.4),
        ),
    ),
    goal=(0.0, 1.5, 0.1),
    goal_low=(-0.3, 1.2, 0.1),
    goal_high=(0.3, 1.5, 0.1),
    tolerance=0.1,
)
