"""One evaluation of F, the env's construction, and the F they give, per commit (asv).

The same quantities as ``python -m perf.speed.evaluation_speed`` prints (its "evaluation of F
(env.step)" and "construction" figures), for the straight tool and the hook, in the default
scene. ``track_free_energy`` records F itself, so a commit that changes the results shows in the
same table as one that changes the speed.
"""

from __future__ import annotations

import numpy as np

from tooldesign_env import ToolDesignEnv

#: The designs timed: the straight tool and the hook (evaluation_speed's first two).
DESIGNS = {"straight": (0.0, 0.0, 0.0), "hook": (0.0, 1.5, 0.0)}


class Evaluation:
    """``env.step`` of one design in an env made once (the plan cache warm), as an optimizer."""

    params = list(DESIGNS)
    param_names = ["design"]
    # A rollout takes 0.1-0.5 s: a few repeats of one call each, within asv's default timeout.
    number = 1
    repeat = (3, 10, 30.0)
    warmup_time = 0.0
    timeout = 300.0

    def setup(self, design: str) -> None:
        """Make the env and evaluate once, so the plan is cached and the world built."""
        self.env = ToolDesignEnv()
        self.env.reset(seed=0)
        self.action = np.asarray(DESIGNS[design], dtype=np.float32)
        self.env.step(self.action)

    def teardown(self, design: str) -> None:
        """Close the env's PyBullet client."""
        self.env.close()

    def time_env_step(self, design: str) -> None:
        """One evaluation of F (s)."""
        self.env.step(self.action)

    def track_free_energy(self, design: str) -> float:
        """F of the design: a change of results between commits shows here."""
        return float(self.env.step(self.action)[4]["free_energy"])

    track_free_energy.unit = "F"  # type: ignore[attr-defined]


class Construction:
    """A new env and its reset, the cost before the first evaluation of a fresh process."""

    number = 1
    repeat = (3, 10, 30.0)
    warmup_time = 0.0
    timeout = 300.0

    def time_construction_and_reset(self) -> None:
        """``ToolDesignEnv()`` and ``reset`` (s); the plan cache on disk, as after a first run."""
        env = ToolDesignEnv()
        try:
            env.reset(seed=0)
        finally:
            env.close()
