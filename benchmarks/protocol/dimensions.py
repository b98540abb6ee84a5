"""The protocol's dimension axis: the tool polynomial's degree d (the design has d coefficients).

Every degree keeps the paper's tool otherwise: arc length 1.1 m, the 0.15 m handle, the round
section, the plan pi_0. Bounds are ``tooldesign_env.default_bounds(d)``: every coefficient in
[-1.5, 1.5] but the linear one, in [-0.5, 0.5] (the linear term tilts the whole tool, so it gets
the narrow range the cubic's has). A tool of degree d is ``y = c1 x^d + ... + cd x``.

Not every design in the box can be used: it may not be buildable (the swept section crosses
itself) or it may overlap the box at the start of the sweep (then it is ``invalid``, with the
env's penalty F). :func:`buildable_fraction` measures both; the command
``tooldesign bench protocol --buildable N`` prints them per degree.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["DEGREES", "Buildable", "bounds_of", "buildable_fraction"]

#: The degrees of the protocol: the paper's cubic, 5 and 8.
DEGREES: tuple[int, ...] = (3, 5, 8)


def bounds_of(degree: int) -> tuple[tuple[float, float], ...]:
    """The coefficient bounds at a degree, (d, 2) as tuples (``default_bounds(d)``).

    Raises:
        ValueError: If ``degree`` is not an int from 1 to the geometry's largest degree.
    """
    from tooldesign_env import default_bounds
    from tooldesign_env.geometry.tool import DEGREE_MAX

    if isinstance(degree, bool) or not isinstance(degree, int) or not 1 <= degree <= DEGREE_MAX:
        raise ValueError(f"degree must be an int from 1 to {DEGREE_MAX}, got {degree!r}")
    return tuple((float(lo), float(hi)) for lo, hi in default_bounds(degree))


@dataclasses.dataclass(frozen=True)
class Buildable:
    """Of ``n`` random designs at a degree: how many could be built, how many were usable.

    Attributes:
        degree: d.
        n: Designs drawn uniformly in :func:`bounds_of` (d).
        buildable: Designs whose tool geometry can be built.
        usable: Buildable designs that do not overlap the box at the start (``None`` when the
            scene was not built).
    """

    degree: int
    n: int
    buildable: int
    usable: int | None

    def text(self) -> str:
        """One line: the fractions in %."""
        share = self.buildable / self.n
        line = f"d = {self.degree}: {self.buildable}/{self.n} buildable ({share:.1%})"
        if self.usable is not None:
            line += f", {self.usable}/{self.n} usable ({self.usable / self.n:.1%})"
        return line


def buildable_fraction(
    degree: int, n: int = 1000, *, seed: int = 0, check_box: bool = True
) -> Buildable:
    """Draw ``n`` designs uniformly in the degree's bounds and count the usable ones.

    Args:
        degree: d.
        n: Designs, 1 to 10^6.
        seed: ``numpy.random.default_rng`` seed.
        check_box: Also build each buildable tool in the default scene and test whether it
            overlaps the box at the start (about 5 ms a design; no simulation).

    Returns:
        The counts.
    """
    from tooldesign_env import ToolSpec
    from tooldesign_env.geometry.tool import make_tool

    bounds = np.asarray(bounds_of(degree))
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 10**6:
        raise ValueError(f"n must be an int from 1 to 1000000, got {n!r}")
    rng = np.random.default_rng(seed)
    designs = rng.uniform(bounds[:, 0], bounds[:, 1], size=(n, degree))
    spec = ToolSpec(degree=degree)
    tools = [make_tool(x, spec) for x in designs]
    buildable = [t for t in tools if t.buildable]
    usable = None
    if check_box:
        import gymnasium as gym

        import tooldesign_env  # noqa: F401  (registers the env)

        env = gym.make("ToolDesign-v0", tool=spec, bounds=bounds)
        try:
            env.reset()
            simulator = env.unwrapped.simulator  # type: ignore[attr-defined]
            # build() returns a BuildResult (no truth value): count the tools it calls usable.
            usable = sum(simulator.build(t, box_mass=0.1).usable for t in buildable)
        finally:
            env.close()
    return Buildable(degree=degree, n=n, buildable=len(buildable), usable=usable)
