"""``puck``: push a round, slippery puck, which slides along a flat tool, to the goal.

The paper's scene and plan with the box replaced by an upright cylinder of the box's width and
height (diameter 0.1 m, 0.2 m high, 0.1 kg) with half the box's friction (0.2: 0.2 against the
floor, 0.1 against the tool, as PyBullet multiplies the pair's). The push between a flat face
and a round one acts through the puck's centre, so the puck slides along a straight tool as it
is pushed instead of being carried square, and slides on when the tool stops; a tool has to
hold it in a bend to carry it along the sweep.

Measured (perf/studies/task_baselines.py): with the box's friction 0.4 the puck's noise floor
was 1.11 % of F (median over 9 designs and 5 nudged scenes), above the 1 % the project asks;
with 0.2, 0.55 %.
"""

from __future__ import annotations

from tooldesign_env.schema import DEFAULT_GOAL, GOAL_HIGH, GOAL_LOW
from tooldesign_env.specs import PlanSpec, SceneSpec
from tooldesign_env.tasks.base import TaskDefinition

__all__ = ["PUCK"]

PUCK = TaskDefinition(
    name="puck",
    title="push a round puck to the goal",
    scene=SceneSpec(box_friction=0.2),
    plan=PlanSpec(),
    plan_reason=(
        "The paper's pi_0 unchanged, so that the puck task differs from push by the object "
        "alone: the same sweep, pull and hold, the same goals (the paper's range), and what "
        "changes is how the object responds to the tool's face."
    ),
    object_shape="cylinder",
    goal=DEFAULT_GOAL,
    goal_low=GOAL_LOW,
    goal_high=GOAL_HIGH,
    tolerance=0.1,
)
