"""One tuning probe: a method with a few config fields replaced, at the default goal.

The probes behind the committed configs (``docs/results/square/rl/tuning.jsonl``, made with the
square section and the 13-link arm; ``docs/rl.md``) are runs of :func:`probe`.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from benchmarks.rl.agents import evaluate_design, run_cmaes, run_random, train_ppo, train_sac
from benchmarks.rl.configs import default_config
from tooldesign_env.schema import DEFAULT_GOAL

__all__ = ["probe"]


def probe(
    method: str, *, episodes: int, seed: int, overrides: dict[str, Any] | None = None
) -> dict[str, Any]:
    """Run ``method`` for ``episodes`` at the default goal and report what tuning looks at.

    Args:
        method: ``"random"``, ``"cmaes"``, ``"ppo"`` or ``"sac"``.
        episodes: episodes to spend, 1 to 100,000.
        seed: the run's seed, 0 to 2^63 - 1.
        overrides: config fields to replace (PPO/SAC), or ``run_cmaes`` keywords (CMA-ES); a
            dict (random sampling takes none).

    Returns:
        ``best`` (best F so far at 32, 64, ... episodes), ``last32_median`` (median F of the
        last 32 episodes), and for PPO/SAC ``final_policy_F`` and ``final_action`` (the
        deterministic policy's design, one more episode not counted in ``best``).

    Raises:
        ValueError: an unknown method or config field, or ``episodes`` out of range.
        TypeError: ``overrides`` is not a dict, or a bad ``episodes`` or ``seed``.
    """
    if method not in ("random", "cmaes", "ppo", "sac"):
        raise ValueError(f"method must be random, cmaes, ppo or sac, got {method!r}")
    if overrides is not None and not isinstance(overrides, dict):
        raise TypeError(
            'overrides must be a table of config fields, e.g. {"n_steps": 16}, got '
            f"{overrides!r} ({type(overrides).__name__})"
        )
    if overrides and method == "random":
        raise ValueError(f"random sampling has no config fields to set, got {overrides!r}")
    over: dict[str, Any] = {
        k: tuple(v) if isinstance(v, list) else v for k, v in (overrides or {}).items()
    }
    started = time.time()
    out: dict[str, Any] = {"method": method, "seed": seed, "over": over}
    if method == "random":
        records = run_random(total_episodes=episodes, seed=seed)
    elif method == "cmaes":
        records = run_cmaes(total_episodes=episodes, seed=seed, **over)
    else:
        config: Any = default_config(method)
        try:
            config = dataclasses.replace(config, **over)
        except TypeError as error:
            raise ValueError(f"bad overrides {over!r} for {method}: {error}") from None
        train = train_ppo if method == "ppo" else train_sac
        trained = train(config, total_episodes=episodes, seed=seed)
        records = trained.records
        final = evaluate_design(trained.model, DEFAULT_GOAL)
    f = np.array([r.free_energy for r in records])
    best = np.minimum.accumulate(f)
    checkpoints = [c for c in (32, 64, 128, 256, 512, 1024) if c <= len(f)]
    out["best"] = {c: round(float(best[c - 1])) for c in checkpoints}
    out["last32_median"] = round(float(np.median(f[-32:])))
    out["secs"] = round(time.time() - started)
    if method in ("ppo", "sac"):
        out["final_policy_F"] = round(final.free_energy)
        out["final_action"] = [round(a, 2) for a in final.action]
    return out
