"""``hook``: pull the box back toward the base, from where a straight tool cannot reach it.

The box starts at (-0.4, 1.2) m, beside the line the tool lies on at the end of the sweep, on
the side hooks bend toward (the cage scene of docs/cage-scene.md). A straight tool passes it by
and never touches it; a hook closes around it at the end of the sweep and the pull drags it
toward the base. The goals lie between the box's start and the base.
"""

from __future__ import annotations

from tooldesign_env.specs import PlanSpec, SceneSpec
from tooldesign_env.tasks.base import TaskDefinition

__all__ = ["HOOK"]

HOOK = TaskDefinition(
    name="hook",
    title="hook the box and pull it back toward the base",
    scene=SceneSpec(box_position=(-0.4, 1.2)),
    plan=PlanSpec(),
    plan_reason=(
        "The paper's pi_0 unchanged: at the end of the sweep the tool points along +y with its "
        "hook side toward -x, where the box stands, and the pull moves the grasp point 0.35 m "
        "straight toward the base. That pull is the only motion that can bring the box nearer "
        "the base, and only a tool curved around the box can transmit it."
    ),
    goal=(-0.5, 0.9, 0.1),
    goal_low=(-0.6, 0.8, 0.1),
    goal_high=(-0.4, 1.05, 0.1),
    tolerance=0.1,
)
