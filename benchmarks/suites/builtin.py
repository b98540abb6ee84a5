"""The built-in suites: the paper's Section IV at two sizes, and the project's own additions."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from benchmarks.suites.config import OptimizerSpec, SuiteConfig, Variant
from tooldesign_env.schema import (
    DEFAULT_GOAL_PRECISION,
    GOAL_HIGH,
    GOAL_LOW,
)

SIZES: tuple[str, ...] = ("smoke", "full")

"""Sizes of the built-in suites: ``smoke`` (CI, minutes for all four), ``full`` (the paper's)."""


def _precision_variants(
    values: Sequence[float], labels: Mapping[float, str] | None = None
) -> tuple[Variant, ...]:
    labels = labels or {}
    return tuple(
        Variant(name=f"p{v:g}", goal_precision=float(v), label=labels.get(v, "")) for v in values
    )


_PAPER_OPTIMIZERS = ("cmaes", "bo", "pso", "random")


_PEERS = ("optuna-tpe", "optuna-cmaes", "nevergrad")


_SMOKE = {"n_seeds": 2, "iterations": 2, "batch_size": 4}


# The seven p^X values of the robustness scatter: 0, 20 and 50 of Table I, 50 as the top (the
# paper's caption calls p^X = 50 the pure-performance end), and 5, 10, 30, 40 in between, with
# 5 added where the two terms of F are of similar size (confidence per step is O(1-10), the goal
# error per step 1/2 p^X |X - X^g|^2 with |X - X^g| of 0.1-1 m).
ROBUSTNESS_PRECISIONS: tuple[float, ...] = (0.0, 5.0, 10.0, 20.0, 30.0, 40.0, 50.0)


OBJECTIVE_LABELS: dict[float, str] = {
    0.0: "pure confidence",
    20.0: "free energy",
    50.0: "pure performance",
}


def _optimizers_suite(size: str) -> SuiteConfig:
    return SuiteConfig(
        name="optimizers",
        description=(
            "CMA-ES, BO, PSO and random sampling on F with p^X = 20, same batch and iterations "
            "(the paper's optimizer comparison)"
        ),
        goal_precision=DEFAULT_GOAL_PRECISION,
        optimizers=tuple(OptimizerSpec(name=n) for n in _PAPER_OPTIMIZERS),
        batch_size=8,
        iterations=15,
        n_seeds=10,
    )


def _peers_suite(size: str) -> SuiteConfig:
    import optimizers

    installed = set(optimizers.available())
    peers = [n for n in _PEERS if n in installed]
    if not peers:
        raise ValueError(
            "optimizer-peers needs Optuna or Nevergrad: install them with "
            "`pip install 'tooldesign[optuna,nevergrad]'`"
        )
    base = _optimizers_suite(size)
    return base.replace(
        description=(
            "the optimizers suite's peer variant: Optuna and Nevergrad (those installed) next to "
            "CMA-ES, same task, budget and seeds"
        ),
        variants=(Variant(name="peers", goal_precision=DEFAULT_GOAL_PRECISION),),
        optimizers=tuple(OptimizerSpec(name=n) for n in ("cmaes", *peers)),
    )


def _precision_sweep_suite(size: str) -> SuiteConfig:
    return SuiteConfig(
        name="precision-sweep",
        description=(
            "CMA-ES designs for p^X in {0, 10, 20, 30, 40, 50}: tool shapes and box paths "
            "(the paper's tool-variation figure)"
        ),
        variants=_precision_variants((0, 10, 20, 30, 40, 50)),
        optimizers=(OptimizerSpec(name="cmaes"),),
        n_seeds=3,
        keep_paths=True,
        figures=("tool-shapes",),
    )


def _robustness_suite(size: str) -> SuiteConfig:
    values = ROBUSTNESS_PRECISIONS if size == "full" else (0.0, 20.0, 50.0)
    return SuiteConfig(
        name="robustness",
        description=(
            "CMA-ES designs for random goals and seven p^X values, each tested under box masses "
            "0.3-0.9 kg: Table I and the robustness scatter"
        ),
        goal_box=tuple(zip(GOAL_LOW, GOAL_HIGH, strict=True)),
        variants=_precision_variants(values, OBJECTIVE_LABELS),
        optimizers=(OptimizerSpec(name="cmaes"),),
        n_seeds=10,
        test_robustness=True,
        figures=("robustness-table", "robustness-scatter"),
    )


def _robust_design_suite(size: str) -> SuiteConfig:
    # The robustness suite's tasks, budget and optimizer, with an objective that asks for
    # robustness directly: does control confidence buy robustness more cheaply?
    base = _robustness_suite(size)
    return base.replace(
        name="robust-design",
        description=(
            "The robust-design baseline: CMA-ES on the goal error averaged over box masses "
            "0.1, 0.5 and 0.9 kg (no confidence term), on the robustness suite's goals, budget "
            "and seeds"
        ),
        objective="expected-goal-error",
        variants=(
            Variant(
                name="robust", goal_precision=DEFAULT_GOAL_PRECISION, label="expected goal error"
            ),
        ),
    )


def _mass_perturbation_suite(size: str) -> SuiteConfig:
    return SuiteConfig(
        name="mass-perturbation",
        description=(
            "box paths under box masses 0.1-0.9 kg for a p^X = 0 and a p^X = 50 CMA-ES design "
            "(the paper's two trajectory figures)"
        ),
        variants=_precision_variants((0, 50), OBJECTIVE_LABELS),
        optimizers=(OptimizerSpec(name="cmaes"),),
        n_seeds=3,
        test_robustness=True,
        keep_paths=True,
        figures=("mass-paths",),
    )


_BUILDERS = {
    "optimizers": _optimizers_suite,
    "precision-sweep": _precision_sweep_suite,
    "robustness": _robustness_suite,
    "mass-perturbation": _mass_perturbation_suite,
    "optimizer-peers": _peers_suite,
    "robust-design": _robust_design_suite,
}


BUILTIN_SUITES: tuple[str, ...] = tuple(_BUILDERS)

"""Names of the built-in suites; the first four are the paper's."""


def builtin_suite(name: str, size: str = "full") -> SuiteConfig:
    """A built-in suite at a size.

    ``full`` is the paper's scale: batch 8, 15 iterations; 10 seeds for ``optimizers`` (and
    ``optimizer-peers``) and 10 goals for ``robustness``; 3 seeds per p^X for
    ``precision-sweep`` and ``mass-perturbation`` (the figures show each p^X's lowest-F design).
    ``smoke`` keeps every variant (``robustness``: p^X in {0, 20, 50} only) with 2 seeds,
    2 iterations and batch 4, so the four paper suites run in CI in a few minutes.

    Args:
        name: One of :data:`BUILTIN_SUITES`.
        size: One of :data:`SIZES`.

    Returns:
        The suite.

    Raises:
        ValueError: If the name or the size is unknown, or (``optimizer-peers``) no peer
            optimizer is installed.
    """
    if not isinstance(name, str) or name not in _BUILDERS:
        raise ValueError(
            f"unknown suite {name!r}; built-in suites: {', '.join(BUILTIN_SUITES)} (or give a "
            "suite file with --config)"
        )
    if not isinstance(size, str) or size not in SIZES:
        raise ValueError(f"unknown size {size!r}; sizes: {', '.join(SIZES)}")
    suite = _BUILDERS[name](size)
    return suite.replace(**_SMOKE) if size == "smoke" else suite
