"""Retest the final designs of a suite: their noise floor, and their robustness over ranges.

A suite's final designs are scored once, in one scene. Pushing is chaotic: a box moved by 0.1 mm
can end millimetres elsewhere, so one score is one sample. This module re-evaluates every final
design of a suite run folder, after the suite, in two ways:

* **noise**: in ``nudges`` scenes whose box start differs by at most ``shift`` (m) and ``turn``
  (rad), drawn once from ``seed`` and the same for every design. The spread of F over them is
  the design's noise floor; the median over the suite's designs is the suite's
  (:func:`noise_floor`). Reports do not call a difference significant below it.
* **stress** (suites that test robustness): in ``repeats`` of those scenes, the design at its
  nominal box mass and then at every mass of ``masses`` and every box friction of
  ``frictions``. Each altered rollout is compared with the nominal one IN THE SAME SCENE (so the
  differences are the change's, not the scene's): robustness -sum_t |X - X_0| (m, per altered
  condition), accuracy -sum_t |X - X^g| (m), control deviation sum_t |U - U_0| (N m) and the
  final distance |X_T - X^g| (m). Table I becomes means over repeats and conditions with
  intervals (see ``benchmarks.reports.suite``).

Results go to ``run_folder/retest/<the design file's path below designs/>``, one JSON per design,
written atomically; a rerun skips designs whose file was written with the same settings, so an
interrupted retest resumes. Command: ``tooldesign retest RUN_FOLDER``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import time
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from pathlib import Path
from typing import Any, cast

import numpy as np

from benchmarks.execution import TaskSettings, make_executor, map_robust, usable_cpus, worker_env
from benchmarks.storage import (
    DESIGNS_DIR,
    INVALID_IN_SCENE,
    json_text,
    read_designs,
    read_manifest,
    read_retests,
    read_run_file,
    retest_outcome,
    retest_path,
    write_retest,
)
from benchmarks.storage.lock import holding
from benchmarks.suites.config import suite_of_manifest
from tooldesign_env.schema import METRICS
from tooldesign_env.specs import is_unordered

__all__ = [
    "FLOOR_CANDIDATES",
    "FLOOR_SCENES",
    "RetestConfig",
    "retest_design",
    "retest_suite",
]

#: Scenes of a noise floor of one design (the protocol's references, the break-even study's
#: tasks): the equivalence rule's 16 (``benchmarks.suites.equivalence``). A new scene's F falls
#: inside the range of n scenes with probability (n - 1) / (n + 1): 50 % for 3 scenes, 75 % for
#: 7, 88 % for 16, so a floor of few scenes is too narrow.
FLOOR_SCENES = 16

#: Designs (best F first) tried for one valid in every nudged scene before a noise floor is
#: given up: one that a 0.1 mm nudge makes unbuildable has no floor.
FLOOR_CANDIDATES = 20

RETEST_VERSION = 1


@dataclasses.dataclass(frozen=True, kw_only=True)
class RetestConfig:
    """How the final designs are retested.

    Attributes:
        nudges: Scenes per design for the noise floor (the first is the scene itself).
        shift: Largest change of the box's start position, m (0.1 mm, which moves the box's
            final position by millimetres: the pushes are chaotic, docs/reproduction.md).
        turn: Largest change of the box's start yaw, rad.
        seed: Seed of the nudges; every design gets the same ones.
        masses: Box masses of the stress test, kg (empty: no stress test).
        frictions: Box friction coefficients of the stress test (empty: none).
        repeats: Scenes (the first ``repeats`` nudges) in which the stress test is repeated.
    """

    nudges: int = 5
    shift: float = 1e-4
    turn: float = 1e-4
    seed: int = 0
    masses: tuple[float, ...] = ()
    frictions: tuple[float, ...] = ()
    repeats: int = 3

    def __post_init__(self) -> None:
        for name in ("nudges", "repeats", "seed"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int):
                raise ValueError(f"RetestConfig.{name} must be an int, got {value!r}")
        if self.seed < 0:
            raise ValueError(f"RetestConfig.seed must be an int >= 0, got {self.seed!r}")
        if not 2 <= self.nudges <= 100:
            raise ValueError(f"RetestConfig.nudges must be in [2, 100], got {self.nudges}")
        if not 1 <= self.repeats <= self.nudges:
            raise ValueError(
                f"RetestConfig.repeats must be in [1, nudges = {self.nudges}], got {self.repeats}"
            )
        for name in ("shift", "turn"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 <= value <= 0.01):
                raise ValueError(f"RetestConfig.{name} must be in [0, 0.01], got {value!r}")
        for name, low, high in (("masses", 0.0, 100.0), ("frictions", 0.0, 10.0)):
            if is_unordered(getattr(self, name)):  # a set would be tested in hash order
                raise TypeError(
                    f"RetestConfig.{name} must be numbers in order (a list or tuple), got "
                    f"{getattr(self, name)!r}"
                )
            values = tuple(float(v) for v in getattr(self, name))
            if not all(math.isfinite(v) and low < v <= high for v in values):
                raise ValueError(f"RetestConfig.{name} must lie in ({low}, {high}], got {values}")
            object.__setattr__(self, name, values)

    def scenes(self, base: Any) -> list[Any]:
        """The nudged copies of the SceneSpec ``base``; the first is ``base`` itself."""
        rng = np.random.default_rng(np.random.SeedSequence(self.seed))
        out = [base]
        x, y = base.box_position
        for _ in range(self.nudges - 1):
            radius = self.shift * math.sqrt(rng.uniform())
            angle = rng.uniform(0.0, 2.0 * math.pi)
            out.append(
                dataclasses.replace(
                    base,
                    box_position=(x + radius * math.cos(angle), y + radius * math.sin(angle)),
                    box_yaw=base.box_yaw + rng.uniform(-self.turn, self.turn),
                )
            )
        return out

    def to_json(self) -> dict[str, Any]:
        """The settings as plain JSON types."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


@dataclasses.dataclass(frozen=True, kw_only=True)
class RetestItem:
    """One design to retest, in a worker."""

    coeffs: tuple[float, ...]
    task: TaskSettings
    config: RetestConfig


def _rollout(
    task: TaskSettings, scene: Any, coeffs: Sequence[float], **changes: Any
) -> dict[str, Any]:
    settings = dataclasses.replace(task, env_kwargs={**dict(task.env_kwargs), "scene": scene})
    if "box_mass" in changes:
        settings = dataclasses.replace(settings, box_mass=changes["box_mass"])
    env = worker_env(settings, series=True)
    info = env.step(np.asarray(coeffs, dtype=np.float64))[4]
    if not info["valid"]:
        raise ValueError(f"{INVALID_IN_SCENE}: {info['invalid_reason']}")
    return cast("dict[Any, Any]", info)


def retest_design(item: RetestItem) -> dict[str, Any]:
    """Noise and stress rows of one design (see the module docstring); runs in a worker."""
    start = time.perf_counter()
    config, task, coeffs = item.config, item.task, item.coeffs
    base = task.task_scene()
    scenes = config.scenes(base)
    goal = np.asarray(task.goal, dtype=np.float64)
    noise, stress = [], []
    for k, scene in enumerate(scenes):
        info = _rollout(task, scene, coeffs)
        noise.append(
            {
                "nudge": k,
                **{name: float(info[name]) for name in METRICS},
            }
        )
        if k >= config.repeats or not (config.masses or config.frictions):
            continue
        x0 = np.asarray(info["box_trajectory"])
        u0 = np.asarray(info["torques"])
        changes = [("mass", m, {"box_mass": m}, scene) for m in config.masses]
        changes += [
            ("friction", f, {}, dataclasses.replace(scene, box_friction=f))
            for f in config.frictions
        ]
        for kind, value, overrides, changed_scene in changes:
            other = _rollout(task, changed_scene, coeffs, **overrides)
            x = np.asarray(other["box_trajectory"])
            u = np.asarray(other["torques"])
            stress.append(
                {
                    "nudge": k,
                    "change": kind,
                    "value": float(value),
                    "robustness": -float(np.sum(np.linalg.norm(x - x0, axis=1))),
                    "accuracy": -float(np.sum(np.linalg.norm(x - goal, axis=1))),
                    "control_deviation": float(np.sum(np.linalg.norm(u - u0, axis=1))),
                    "final_distance": float(np.linalg.norm(x[-1] - goal)),
                }
            )
    return {"noise": noise, "stress": stress, "retest_time": time.perf_counter() - start}


def default_config(suite: Any) -> RetestConfig:
    """Noise only, or (a suite that tests robustness) noise and stress over ranges."""
    if not getattr(suite, "test_robustness", False):
        return RetestConfig()
    # The paper's masses (0.3-0.9 kg) widened to 0.2-1.0 kg, and the box's friction halved and
    # raised by half around its 0.4: 26 rollouts per design with 5 nudges and 3 repeats.
    return RetestConfig(masses=(0.2, 0.4, 0.6, 0.8, 1.0), frictions=(0.2, 0.6))


def retest_task(suite: Any, record: Mapping[str, Any]) -> TaskSettings:
    """The task a stored final design is retested on: its goal, p^X and mass, the suite's env.

    Args:
        suite: The suite's :class:`~benchmarks.suites.config.SuiteConfig`.
        record: The design file's record (``goal``, ``goal_precision``, ``box_mass``).
    """
    # The env settings every run of the suite was scored with (its scene, which the nudges start
    # from, its tool and its bounds), but one rollout per evaluation: the noise floor is that of
    # a single evaluation, whatever scene_samples the suite averaged over.
    design_task = suite.runs()[0].design.task()
    extra = {k: v for k, v in design_task.env_kwargs if k != "scene_samples"}
    return TaskSettings(
        goal=record["goal"],
        goal_precision=record["goal_precision"],
        box_mass=record["box_mass"],
        estimator=suite.estimator,
        env_kwargs=extra,
    )


def retest_suite(
    run_folder: str | os.PathLike[str],
    config: RetestConfig | None = None,
    *,
    executor: Executor | None = None,
    workers: int | None = None,
) -> list[Path]:
    """Retest every final design of a suite run folder; resumes an interrupted retest.

    Args:
        run_folder: A suite run folder with design files.
        config: The retest; :func:`default_config` of the folder's suite if None.
        executor: Where to run; a process pool of ``workers`` if None.
        workers: Worker processes of the default pool.

    Returns:
        The retest files written in this call.

    Raises:
        FileNotFoundError: If the folder has no manifest.
        ValueError: If it is not a suite run folder, or has no finished design, or a design or
            retest file is malformed or differs from its recorded checksum, or another process
            is still writing the folder (retest it when its run has ended).
    """
    folder = Path(run_folder)
    with holding(folder):  # a run still writing the folder would overwrite the checksums
        pass
    suite = suite_of_manifest(read_manifest(folder))
    config = config or default_config(suite)
    settings = json.loads(json_text(config.to_json()))  # as stored: tuples become lists
    # A design or retest file that differs from the checksum the manifest records for it, or
    # that is malformed, is refused (naming it) before anything is simulated.
    finished = read_designs(folder)
    read_retests(folder)
    pending: list[tuple[Path, RetestItem, dict[str, Any]]] = []
    for path in sorted((folder / DESIGNS_DIR).rglob("seed=*.json")):
        if path.name.endswith(".paths.json"):
            continue
        record = json.loads(read_run_file(folder, path))  # checked by read_designs above
        if record.get("status") != "ok" or not record.get("coefficients"):
            continue
        target = retest_path(folder, path)
        if os.path.lexists(target):
            try:
                done = json.loads(read_run_file(folder, target))  # checked by read_retests
            except (OSError, ValueError):
                done = {}
            # A retest that broke for a reason of its own (a worker that died) is tried again;
            # a design invalid in a nudged scene is an outcome, kept.
            if done.get("settings") == settings and retest_outcome(done) != "failed":
                continue
        task = retest_task(suite, record)
        item = RetestItem(coeffs=tuple(record["coefficients"]), task=task, config=config)
        pending.append((target, item, record))
    if not pending and not finished:
        raise ValueError(f"{folder} has no finished design to retest")
    written: list[Path] = []
    with contextlib.ExitStack() as stack:
        pool = executor or stack.enter_context(make_executor("process", workers=workers))
        # In chunks, so that an interrupted retest keeps what it finished.
        chunk = 2 * int(getattr(pool, "max_workers", None) or usable_cpus())
        for begin in range(0, len(pending), chunk):
            part = pending[begin : begin + chunk]
            outcomes = map_robust(pool, retest_design, [item for _, item, _ in part])
            for (target, _, record), (result, exc, _) in zip(part, outcomes, strict=True):
                out = {
                    "format_version": RETEST_VERSION,
                    "settings": settings,
                    **{k: record[k] for k in ("variant", "label", "optimizer", "seed", "goal")},
                    "goal_precision": record["goal_precision"],
                    "coefficients": record["coefficients"],
                    "error": "" if exc is None else f"{type(exc).__name__}: {exc}",
                    **(result or {"noise": [], "stress": []}),
                }
                # Its SHA-256 goes into the manifest, which report and retest check.
                written.append(write_retest(folder, target, json_text(out)))
    return written
