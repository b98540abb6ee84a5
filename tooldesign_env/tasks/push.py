"""``push``: the paper's task, ``ToolDesign-v0``: sweep the box along the floor to a goal.

Nothing here changes what ``ToolDesign-v0`` does: the default scene, the default plan, and any
goal in the workspace, so every committed result stays bit for bit what it was.
"""

from __future__ import annotations

from tooldesign_env.schema import DEFAULT_GOAL, GOAL_HIGH, GOAL_LOW
from tooldesign_env.specs import PlanSpec, SceneSpec
from tooldesign_env.tasks.base import TaskDefinition

__all__ = ["PUSH"]

PUSH = TaskDefinition(
    name="push",
    title="push the box along the floor to the goal (the paper's task)",
    scene=SceneSpec(),
    plan=PlanSpec(),
    plan_reason=(
        "The paper's pi_0: the tool is lowered beside the box, swept a quarter turn about the "
        "base from +x to +y (turning with the sweep so that it points radially at both ends), "
        "pulled toward the base and held. The sweep moves the box along an arc; the pull lets a "
        "hook drag it in; the 6 s hold makes the final position weigh in F (docs/model.md)."
    ),
    goal=DEFAULT_GOAL,
    goal_low=GOAL_LOW,
    goal_high=GOAL_HIGH,
    # One box width: the straight tool, which ends 0.08 m from the default goal, succeeds.
    tolerance=0.1,
    accepts_any_goal=True,
)
