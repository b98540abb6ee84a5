"""Semi-amortized design: a learned designer proposes, a few steps of CMA-ES refine.

A saved policy (a card of the contextual method, PPO or SAC, :mod:`benchmarks.rl.policies`)
gives one design per task at the cost of one evaluation. Per-goal CMA-ES finds better designs
but starts from nothing. Warm-starting joins them (Amos, "Tutorial on amortized optimization",
2022): the policy's design is evaluated first, then CMA-ES runs at the task with its mean at
that design and a step size from the policy's own spread:

- **contextual** cards, by the card's ``mode``, as its proposal is made
  (:func:`proposal_spread`):

  - ``"kernel"`` (the proposal is the kernel-weighted mean of the training tasks' best
    designs): the kernel-weighted RMS distance of those designs from the proposal, per
    coordinate, with the card's bandwidth as the kernel width and its task distance: where the
    training optima near the task disagree, the search starts wide.
  - ``"nearest"`` (the proposal is the best design of the nearest training task; the study's
    cards): the RMS distance, per coordinate, of the second-nearest training task's best design
    from the proposal, with the same task distance: how far the rule's answer jumps if the
    task were a little nearer its runner-up. A card of one training task has no runner-up: no
    spread (:data:`DEFAULT_SIGMA0`). The kernel's weights are not used, as the proposal does
    not use them.
- **PPO**: the policy's Gaussian standard deviation exp(log_std), the mean over coordinates.
- **SAC**: the actor's squashed-Gaussian standard deviation at the task, std * (1 - tanh(mu)^2)
  (the spread of tanh(u) to first order), the mean over coordinates.
- anything else (a user's callable): no spread; :data:`DEFAULT_SIGMA0` is used.

The spread s is in action units (the [-1, 1] box, width 2), so the step size as a fraction of
the box is s / 2, clipped to [:data:`SIGMA0_MIN`, :data:`SIGMA0_COLD`]: never wider than the
cold start's 0.3 (then the proposal would be forgotten), never so narrow that CMA-ES cannot move.

Two users of the same rule: :class:`WarmStartDesigner`, the ask/tell "optimizer" of
``tooldesign design --policy CARD --refine N`` (one design per iteration: the proposal, then N
CMA-ES samples), and :func:`run_warm_cmaes`, the loop of the break-even study
(:mod:`benchmarks.rl.breakeven`) on ``ToolDesignRL-v0``.

This module is not in :mod:`optimizers`: a policy needs the RL env to read its observation.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from benchmarks.rl.agents import ContextualPolicy, EpisodeLog, EpisodeRecord, make_env
from benchmarks.rl.designer import _check_in_bounds
from optimizers.base import Optimizer

__all__ = [
    "DEFAULT_SIGMA0",
    "SIGMA0_COLD",
    "SIGMA0_MIN",
    "WARM_START_DESIGNER",
    "WarmStartDesigner",
    "check_warm_settings",
    "proposal_spread",
    "run_warm_cmaes",
    "warm_start_proposal",
    "warm_sigma0",
]

WARM_START_DESIGNER = "benchmarks.rl.warmstart:WarmStartDesigner"
"""The optimizer name (``module:Class``) of a design run warm-started from a saved policy."""

#: The cold start's step size (a fraction of the box): ``run_cmaes`` and the rl suite's CMA-ES.
SIGMA0_COLD = 0.3

#: The smallest warm step size: below it CMA-ES hardly leaves the proposal in 64 evaluations.
SIGMA0_MIN = 0.02

#: The step size when the policy has no spread to read (a user's callable): a third of the cold.
DEFAULT_SIGMA0 = 0.1


def _inner(policy: Any) -> Any:
    """The policy network of a Stable-Baselines3 model (or the policy itself)."""
    return getattr(policy, "policy", policy)


def _contextual_spread(policy: ContextualPolicy, obs: np.ndarray) -> float | None:
    """A contextual card's spread, by the rule of its ``mode`` (the module docstring)."""
    d2 = np.sum((policy.goals - obs[:3]) ** 2, axis=1)
    if policy.masses is not None and obs.size >= 4:
        d2 = d2 + (policy.mass_scale * (policy.masses - obs[3])) ** 2
    proposal, _ = policy.predict(obs)
    deviation = np.sum((policy.actions - np.asarray(proposal, dtype=np.float64)) ** 2, axis=1)
    width = policy.actions.shape[1]
    if policy.mode == "nearest":
        if len(d2) < 2:
            return None  # one training task: no runner-up to measure the rule's change by
        # The proposal is the nearest training task's optimum (argmin takes the first of ties,
        # as predict does); the runner-up is the next in the same order.
        runner_up = int(np.argsort(d2, kind="stable")[1])
        return float(math.sqrt(float(deviation[runner_up]) / width))
    logw = -d2 / (2.0 * policy.bandwidth**2)
    w = np.exp(logw - logw.max())
    return float(math.sqrt(float(np.dot(w, deviation)) / (w.sum() * width)))


def proposal_spread(policy: Any, observation: Any) -> float | None:
    """How uncertain ``policy`` is about its design for ``observation``, in action units.

    Args:
        policy: A :class:`~benchmarks.rl.agents.ContextualPolicy`, a Stable-Baselines3 PPO or
            SAC model or policy network (as :func:`~benchmarks.rl.policies.load_policy` gives),
            or anything with ``predict``.
        observation: The task (x, y, z in m, box mass in kg), as the env observes it.

    Returns:
        The spread (>= 0) in the [-1, 1] action box, or None for a policy with no spread to
        read (see the module docstring for each rule).
    """
    obs = np.asarray(observation, dtype=np.float64).ravel()
    if isinstance(policy, ContextualPolicy):
        return _contextual_spread(policy, obs)
    net = _inner(policy)
    log_std = getattr(net, "log_std", None)
    if log_std is not None and hasattr(log_std, "detach"):  # PPO: state-independent Gaussian
        return float(np.mean(np.exp(log_std.detach().cpu().numpy().astype(np.float64))))
    actor = getattr(net, "actor", None)
    if actor is not None and hasattr(actor, "get_action_dist_params"):  # SAC: squashed Gaussian
        import torch

        with torch.no_grad():
            tensor = torch.as_tensor(obs[np.newaxis, :], dtype=torch.float32)
            mean, log_std_sac, _ = actor.get_action_dist_params(tensor)
        mu = mean.cpu().numpy().astype(np.float64).ravel()
        std = np.exp(log_std_sac.cpu().numpy().astype(np.float64).ravel())
        return float(np.mean(std * (1.0 - np.tanh(mu) ** 2)))
    return None


def warm_sigma0(spread: float | None) -> float:
    """The CMA-ES step size (a fraction of the box) for a policy's ``spread`` (action units).

    ``spread / 2`` (the action box is 2 wide) clipped to [:data:`SIGMA0_MIN`,
    :data:`SIGMA0_COLD`]; :data:`DEFAULT_SIGMA0` when there is no spread (None or not finite).
    """
    if spread is None or not math.isfinite(spread):
        return DEFAULT_SIGMA0
    return float(min(max(spread / 2.0, SIGMA0_MIN), SIGMA0_COLD))


def _check_sigma0(sigma0: Any) -> float | None:
    if sigma0 is None:
        return None
    if isinstance(sigma0, bool) or not isinstance(sigma0, (int, float, np.number)):
        raise TypeError(f"sigma0 must be a number in [{SIGMA0_MIN:g}, 1] or None, got {sigma0!r}")
    if not (math.isfinite(sigma0) and SIGMA0_MIN <= sigma0 <= 1):
        raise ValueError(
            f"sigma0 must be in [{SIGMA0_MIN:g}, 1] (a fraction of the box), got {sigma0!r}"
        )
    return float(sigma0)


def _check_popsize(popsize: Any) -> int:
    if isinstance(popsize, bool) or not isinstance(popsize, (int, np.integer)):
        raise TypeError(f"popsize must be an int from 2 to 1000, got {popsize!r}")
    if not 2 <= popsize <= 1000:
        raise ValueError(f"popsize must be an int from 2 to 1000, got {popsize!r}")
    return int(popsize)


def check_warm_settings(sigma0: Any, popsize: Any) -> tuple[float | None, int]:
    """``(sigma0, popsize)`` of a warm start, checked (what :class:`WarmStartDesigner` takes).

    Raises:
        TypeError / ValueError: ``sigma0`` not None or a number in [0.02, 1], ``popsize`` not
            an int from 2 to 1000; the message names the value.
    """
    return _check_sigma0(sigma0), _check_popsize(popsize)


def warm_start_proposal(
    policy: str | os.PathLike[str],
    goal: Sequence[float],
    *,
    box_mass: float,
    sha256: str | None = None,
    allow_pickle: bool = False,
) -> tuple[np.ndarray, float | None]:
    """A saved policy's design for a task and its spread: where a warm start begins.

    Args:
        policy: Path of the policy card.
        goal: (x, y, z) in m.
        box_mass: kg.
        sha256: The digest the policy must have (checked before it is loaded), or None.
        allow_pickle: Load a policy card of format 1 (see :func:`benchmarks.rl.load_policy`).

    Returns:
        The design's coefficients (n,) (bit for bit those of ``tooldesign rl design``) and
        :func:`proposal_spread` (action units, None for no spread).

    Raises:
        TypeError / ValueError / FileNotFoundError: a bad card, goal or mass (as
            :func:`benchmarks.rl.design_for_goal`).
    """
    from benchmarks.rl.policies import load_policy, policy_env_kwargs

    loaded, card = load_policy(policy, allow_pickle=allow_pickle, sha256=sha256)
    env = make_env(**policy_env_kwargs(card), reward="free-energy")
    try:
        obs, _ = env.reset(options={"goal": tuple(goal), "box_mass": box_mass})
        action, _ = loaded.predict(obs, deterministic=True)
        action = np.clip(np.asarray(action, dtype=np.float32).ravel(), -1.0, 1.0)
        coefficients = np.asarray(env.to_coefficients(action), dtype=np.float64)
    finally:
        env.close()
    return coefficients, proposal_spread(loaded, obs)


class WarmStartDesigner(Optimizer):
    """The policy's design first, then CMA-ES from it: one design per ask (``batch_size`` 1).

    The first ask is the policy's zero-shot design for the task (bit for bit the coefficients
    ``tooldesign rl design`` prints). Every later ask is the next sample of a CMA-ES
    (``optimizers.make("cmaes")``, seeded with ``seed``) whose mean is that design and whose step
    size is ``sigma0`` or, if None, :func:`warm_sigma0` of :func:`proposal_spread`; CMA-ES is
    told each generation of ``popsize`` samples once all of it is told. The proposal is not
    told to CMA-ES (it is its mean). Deterministic for a seed, so a design run replays it on
    resume.

    Args:
        bounds: The run's coefficient bounds; the policy's design must lie inside them.
        batch_size: Must be 1: the designs come one at a time (the first is the proposal).
        seed: Seed of the CMA-ES.
        policy: Path of the policy card (:func:`benchmarks.rl.save_policy`).
        goal: (x, y, z) in m, the task's goal.
        box_mass: kg, the task's box mass.
        sha256: :func:`benchmarks.rl.policies.policy_digest` of the policy when the run began;
            checked before the policy is loaded.
        sigma0: CMA-ES step size as a fraction of the box, in [0.02, 1]; None: the policy's.
        popsize: CMA-ES population size, 2 to 1000 (default 8, the rl suite's).
        allow_pickle: Load a policy card of format 1 (see :func:`benchmarks.rl.load_policy`).

    Raises:
        ValueError / TypeError: A batch size other than 1, a bad sigma0 or popsize, a policy
            whose digest is not ``sha256``, a bad card, goal or mass, or a design outside
            ``bounds``.
        FileNotFoundError: No such policy.
    """

    generational: ClassVar[bool] = False

    def __init__(
        self,
        bounds: Any = None,
        *,
        batch_size: int = 1,
        seed: Any = None,
        policy: str | os.PathLike[str],
        goal: Sequence[float],
        box_mass: float,
        sha256: str,
        sigma0: float | None = None,
        popsize: int = 8,
        allow_pickle: bool = False,
    ) -> None:
        if batch_size != 1 or isinstance(batch_size, bool):
            raise ValueError(
                "a warm-started design asks one design at a time (the proposal, then CMA-ES's "
                f"samples): batch_size must be 1, got {batch_size!r}"
            )
        chosen_sigma = _check_sigma0(sigma0)
        population = _check_popsize(popsize)
        super().__init__(bounds, batch_size=1, seed=seed)
        import optimizers

        c, self.spread = warm_start_proposal(
            policy, goal, box_mass=box_mass, sha256=sha256, allow_pickle=allow_pickle
        )
        low, high = self._low, self._high
        _check_in_bounds(c, low, high)
        self.coefficients: np.ndarray = c
        self._proposal_unit: np.ndarray = np.asarray((c - low) / self._span)
        self.sigma0 = warm_sigma0(self.spread) if chosen_sigma is None else chosen_sigma
        self.popsize = population
        self._cmaes = optimizers.make(
            "cmaes",
            bounds=np.stack([low, high], axis=1),
            batch_size=population,
            seed=seed,
            sigma0=self.sigma0,
            x0=c,
        )
        self._proposed = False
        self._queue: list[tuple[int, np.ndarray]] = []  # CMA-ES's (id, physical x) not asked
        self._outer: dict[int, int] = {}  # our id -> CMA-ES's id
        self._generation: dict[int, float] = {}  # CMA-ES's id -> told value (this generation)
        self._generation_ids: tuple[int, ...] = ()

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        if not self._proposed:
            self._proposed = True
            return np.asarray(self._proposal_unit[np.newaxis, :])
        if not self._queue:
            if len(self._generation) < len(self._generation_ids):
                # Not reachable through the design loop (it tells each design before the next
                # ask); a caller who asks ahead gets this instead of a silent mix of generations.
                raise RuntimeError(
                    "tell every design of the CMA-ES generation before asking past it"
                )
            batch = self._cmaes.ask()
            self._generation_ids = tuple(int(i) for i in batch.ids)
            self._generation = {}
            self._queue = [(int(i), np.asarray(x)) for i, x in zip(batch.ids, batch.x, strict=True)]
        inner, x = self._queue.pop(0)
        self._outer[ids[0]] = inner
        return np.asarray(((x - self._low) / self._span)[np.newaxis, :])

    def _to_physical(self, u: np.ndarray) -> np.ndarray:
        # The proposal's own coefficients, bit for bit (as PolicyDesigner gives them): the way
        # through the unit box and back may round the last digit.
        physical = super()._to_physical(u)
        if u.ndim == 1:
            return self.coefficients.copy() if np.array_equal(u, self._proposal_unit) else physical
        for k, row in enumerate(u):
            if np.array_equal(row, self._proposal_unit):
                physical[k] = self.coefficients
        return physical

    def _tell(
        self, ids: tuple[int, ...], x: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        for i, value, bad in zip(ids, values, failed, strict=True):
            inner = self._outer.pop(i, None)
            if inner is None:
                continue  # the proposal: CMA-ES's mean, not one of its samples
            self._generation[inner] = math.nan if bad else float(value)
        if self._generation_ids and len(self._generation) == len(self._generation_ids):
            told = [self._generation[i] for i in self._generation_ids]
            self._cmaes.tell(list(self._generation_ids), told)
            self._generation = {}
            self._generation_ids = ()


def run_warm_cmaes(
    policy: Any,
    *,
    total_episodes: int,
    seed: int,
    goal: Sequence[float],
    box_mass: float,
    sigma0: float | None = None,
    popsize: int = 8,
    env: Any = None,
) -> tuple[list[EpisodeRecord], float]:
    """The policy's design at a task, then CMA-ES from it, ``total_episodes`` episodes in all.

    The break-even study's warm-started method, on ``ToolDesignRL-v0`` in the [-1, 1] action
    box (as :func:`~benchmarks.rl.agents.run_cmaes`, the cold start, with ``x0`` the proposal
    and ``sigma0`` the policy's). Episode 1 is the zero-shot design; CMA-ES's behaviour does not
    depend on the budget, so the first n episodes are the run of budget n.

    Args:
        policy: Anything with ``predict(observation, deterministic=True)``.
        total_episodes: Episodes in all (the proposal included), >= 1.
        seed: Seed of the CMA-ES.
        goal: (x, y, z) in m.
        box_mass: kg.
        sigma0: Step size as a fraction of the box; None: :func:`warm_sigma0` of the policy's
            spread.
        popsize: CMA-ES population size.
        env: A ``ToolDesignRL-v0`` env to reuse (the task's tool and scene); a fresh default
            one if None.

    Returns:
        The episodes, in order, and the step size used.

    Raises:
        TypeError / ValueError: bad ``total_episodes``, ``seed``, ``sigma0`` or ``popsize``.
    """
    import optimizers
    from benchmarks.rl.agents import _check_episodes, _check_seed, _run_generations

    total = _check_episodes(total_episodes)
    seed = _check_seed(seed)
    chosen_sigma = _check_sigma0(sigma0)
    population = _check_popsize(popsize)
    if not hasattr(policy, "predict"):
        raise TypeError(f"policy must have a predict(observation) method, got {policy!r}")
    own = env is None
    logged = EpisodeLog(env if env is not None else make_env())
    options = {"goal": tuple(goal), "box_mass": box_mass}
    try:
        obs, _ = logged.reset(options=options)
        action, _ = policy.predict(obs, deterministic=True)
        proposal = np.clip(np.asarray(action, dtype=np.float32).ravel(), -1.0, 1.0)
        step = warm_sigma0(proposal_spread(policy, obs)) if chosen_sigma is None else chosen_sigma
        logged.step(proposal)
        opt = optimizers.make(
            "cmaes",
            bounds=[[-1.0, 1.0]] * len(proposal),
            batch_size=population,
            seed=seed,
            sigma0=step,
            x0=proposal.astype(np.float64),
        )
        _run_generations(opt, logged, options, total)
    finally:
        if own:
            logged.close()
    return logged.records, step
