"""``puck``: PROVISIONAL."""

from __future__ import annotations

from tooldesign_env.schema import DEFAULT_GOAL, GOAL_HIGH, GOAL_LOW
from tooldesign_env.specs import PlanSpec, SceneSpec
from tooldesign_env.tasks.base import TaskDefinition

__all__ = ["PUCK"]

PUCK = TaskDefinition(
    name="puck",
    title="push a round puck to the goal",
    scene=SceneSpec(),
    plan=PlanSpec(),
    plan_reason="",
    object_shape="cylinder",
    goal=DEFAULT_GOAL,
    goal_low=GOAL_LOW,
    goal_high=GOAL_HIGH,
    tolerance=0.1,
)
