"""A worker's env cache is bounded: the least recently used env is closed, and F does not care.

The benchmark protocol's workers meet new env settings in every cell (each instance has its own
box friction, each nudged scene its own box start); before the bound, a worker of the full
references kept every env it had made and grew by gigabytes.
"""

from __future__ import annotations

import pytest

from benchmarks.design import DesignConfig
from benchmarks.execution import ENV_CACHE_SIZE, clear_env_cache, worker_env
from benchmarks.execution.evaluator import EvaluationRequest, evaluate_design


def _task(friction: float):
    return DesignConfig(scene={"box_friction": friction}).task()


def test_a_worker_keeps_at_most_env_cache_size_envs_and_closes_the_oldest():
    clear_env_cache()
    try:
        frictions = [0.30 + 0.01 * i for i in range(ENV_CACHE_SIZE + 2)]
        envs = [worker_env(_task(f)) for f in frictions]
        assert envs[0].unwrapped.simulator.world._client is None  # closed: its client released
        assert envs[-1].unwrapped.simulator.world._client is not None
        kept = [worker_env(_task(f)) for f in frictions[-ENV_CACHE_SIZE:]]
        assert [e is k for e, k in zip(envs[-ENV_CACHE_SIZE:], kept, strict=True)] == [
            True
        ] * ENV_CACHE_SIZE
    finally:
        clear_env_cache()


@pytest.mark.slow
def test_f_is_the_same_from_a_fresh_env_and_from_a_reused_one():
    clear_env_cache()
    try:
        request = EvaluationRequest(coeffs=(0.5, -0.3, 0.2), task=_task(0.37))
        fresh = evaluate_design(request)
        reused = evaluate_design(request)
        for f in (0.31, 0.32, 0.33, 0.34, 0.35):  # evict the env of 0.37
            worker_env(_task(f))
        remade = evaluate_design(request)
        assert fresh["status"] == "ok"
        for metric in ("free_energy", "goal_error", "confidence", "final_distance"):
            assert fresh[metric] == reused[metric] == remade[metric], metric
    finally:
        clear_env_cache()
