"""``obstacle``: carry the box around a curb that stands across its way to the goal.

The scene is the paper's (the box at radius 1.35 m, 30 degrees from the base's x axis) with a
curb 0.04 m high, 0.05 m thick, standing radially at 60 degrees from radius 1.3 to 1.7 m:
across the arc on which the sweep pushes the box (a straight tool carries it at radius 1.33 to
1.52 m), between the box's start and the goals, which lie beyond the curb as seen along that
arc (x in [-0.35, -0.15], y in [0.7, 1.0] m, at 98.5 to 116.6 degrees). "Between" means
across the box's path under the plan, not across the straight segment from the box to a goal:
that segment crosses the curb's line 0.79 to 0.97 m from the base, 0.33 to 0.51 m inside its
inner end, which is the way around it (docs/tasks.md). The curb is lower than the
tool (the bottom of its section is 0.065 m above the floor), so it stops the box and not the
tool: a tool that pushes the box along the arc (the straight tool, mild bows, a tilted tool)
leaves it tipped onto the curb, and only a tool that holds the box in a forward bend or a
hook, nearer the base than the curb's inner end, carries it around and on to the goal.

Measured with ``perf/studies/task_placements.py --walls`` (docs/tasks.md, output
docs/results/tasks/walls-output.txt): a wall as high as the old post (0.4 m) across the box's
way stops every tool, since the tool sweeps every radius it reaches; a curb stops the box
alone. The inner end at 1.3 m lets the bow (0, 0.6, 0) carry the box inside it; from 1.2 m it
stops that bow too. The curb's friction is the floor's, 1.0: with 0.5 the boxes tipped onto it
landed differently under the retest's nudges (F's relative range 1.9 % for the straight tool,
7.5 % for a tilted one), with 0.2 most slid off and fell (up to 36 % over the noise-floor set
of the baselines), with 1.0 they stay (0.6 and 0.4 %; over the noise-floor set a median of
0.47 %, largest 3.1 %). The goal range is where the 64 random designs of the baselines that
carry the box around the curb leave it (2 to 9 of them succeed at each goal of it); no design
shot the box away. A box that ends tipped onto the curb is not at the goal wherever its centre
is: ``TaskDefinition.max_tilt`` and ``height_tolerance`` say so.

The task's first design had a post beyond the box's way (radius 1.75 m, 60 degrees) that
stopped tools reaching far out; it did not stand between the box and the goal, as issue 35
asks, and was replaced by this curb (docs/tasks.md).
"""

from __future__ import annotations

import math

from tooldesign_env.specs import PlanSpec, SceneSpec
from tooldesign_env.tasks.base import Obstacle, TaskDefinition

__all__ = ["CURB_ANGLE", "CURB_HEIGHT", "CURB_RADII", "OBSTACLE"]

#: The curb's angle about the base from the x axis, rad: across the box's way, 30 degrees on
#: from its start.
CURB_ANGLE = math.radians(60.0)

#: The radii the curb spans, m: from inside the box's way (the straight tool carries the box at
#: 1.33 to 1.52 m) to beyond where boxes pushed outward pass.
CURB_RADII = (1.3, 1.7)

#: The curb's height, m: below the tool (the bottom of its section is 0.065 m above the floor).
CURB_HEIGHT = 0.04

OBSTACLE = TaskDefinition(
    name="obstacle",
    title="carry the box around a curb across its way to the goal",
    scene=SceneSpec(),
    plan=PlanSpec(),
    plan_reason=(
        "The paper's pi_0 unchanged, because its sweep is what puts the curb in the box's "
        "way: the sweep pushes the box along an arc around the base into the curb, so a tool "
        "that only pushes leaves it there, and a tool must hold the box in a bend to carry it "
        "on a smaller radius around the curb's inner end; the pull that follows brings the "
        "box toward the base, to the goals, which only a tool holding it can do. The grasp "
        "height stays 0.08 m: the tool's underside, 0.065 m up, passes over the 0.04 m curb, "
        "and a grasp high enough to pass over a wall taller than the box would pass over the "
        "box too."
    ),
    obstacles=(
        Obstacle(
            name="curb",
            position=(
                sum(CURB_RADII) / 2 * math.cos(CURB_ANGLE),
                sum(CURB_RADII) / 2 * math.sin(CURB_ANGLE),
            ),
            size=(CURB_RADII[1] - CURB_RADII[0], 0.05, CURB_HEIGHT),
            yaw=CURB_ANGLE,
            friction=1.0,
        ),
    ),
    goal=(-0.25, 0.75, 0.1),
    goal_low=(-0.35, 0.7, 0.1),
    goal_high=(-0.15, 1.0, 0.1),
    tolerance=0.1,
)
