"""``obstacle``: sweep the box past a fixed post that stops a straight tool.

The scene is the paper's (the box at radius 1.35 m, 30 degrees from the base's x axis) with a
post 0.1 x 0.1 x 0.4 m standing at radius 1.75 m, 60 degrees: beyond the box's way around the
base, within the reach of every tool that points straight out (a straight tool's tip sweeps
radius 1.67 to 1.88 m). A straight tool, or one bent backward, catches on the post half way
through the sweep and the box stays where the tool left it; a tool bowed toward the side that
leads the sweep passes inside the post and carries the box on. The goals are where such tools
bring the box.

Placements measured with perf/studies/task_placements.py (docs/tasks.md): a post at radius 1.6
m, 55 degrees, in the box's own way, let the hook (0, 1.5, 0) squeeze the box against it and
shoot it 5.3 m from its start, a chaotic outcome; at 45 degrees no tool was held up; at 70
degrees the straight tool was held up and still brought the box to 0.07 m of the push goal.
At 1.75 m and 60 degrees the straight tool, a tilted one and one bowed backward are held up (20
to 54 mm off their plan), the forward bows and the hooks pass.
"""

from __future__ import annotations

import math

from tooldesign_env.specs import PlanSpec, SceneSpec
from tooldesign_env.tasks.base import Obstacle, TaskDefinition

__all__ = ["OBSTACLE", "POST_ANGLE", "POST_RADIUS"]

#: Where the post stands: its distance from the base (m) and its angle from the x axis (rad).
POST_RADIUS = 1.75
POST_ANGLE = math.radians(60.0)

OBSTACLE = TaskDefinition(
    name="obstacle",
    title="sweep the box to the goal past a fixed post that a straight tool catches on",
    scene=SceneSpec(),
    plan=PlanSpec(),
    plan_reason=(
        "The paper's pi_0 unchanged, because its sweep is what the post is placed against: "
        "the tool turns with the grasp point so that it points out from the base, so how far "
        "out it reaches at the post's angle is set by its shape alone. A tool that reaches "
        "past the post is held up there (its grasp point pushed centimetres off the plan); a "
        "tool bowed forward passes inside it, and the "
        "pull and hold that follow are the push task's."
    ),
    obstacles=(
        Obstacle(
            name="post",
            position=(POST_RADIUS * math.cos(POST_ANGLE), POST_RADIUS * math.sin(POST_ANGLE)),
            size=(0.1, 0.1, 0.4),
        ),
    ),
    goal=(-0.25, 1.3, 0.1),
    goal_low=(-0.4, 1.05, 0.1),
    goal_high=(-0.1, 1.35, 0.1),
    tolerance=0.1,
)
