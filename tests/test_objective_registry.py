"""A new estimator or objective is one class and one registration line: toys run through the env.

The toys are defined here, registered for a test and removed after it, so that the registries'
names in other tests' messages stay the built-in ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from tooldesign_env import ObjectiveSpec, ToolDesignEnv
from tooldesign_env.objective import (
    ObjectiveTerms,
    Recording,
    Rollout,
    SceneAveraged,
    Sensitivities,
    TrajectoryEstimator,
    estimator_names,
    make_estimator,
    make_objective,
    objective_names,
    register_estimator,
    register_objective,
    unregister_estimator,
    unregister_objective,
)

#: The toy's one sensitivity, m / N m: one joint moves the box along x while the box moves.
TOY_GAIN = 1e-3


@dataclass(frozen=True)
class MovingBoxEstimator:
    """dX/dU = TOY_GAIN on joint 1 along x at every step in which the box moved, else 0.

    It asks for everything a rollout can record, and checks it got it: the contact log and
    snapshots to replay from.
    """

    name: str = "toy"
    seen: list[Rollout] | None = None

    @classmethod
    def from_spec(cls, spec: ObjectiveSpec) -> MovingBoxEstimator:
        return cls(seen=SEEN)

    @property
    def recording(self) -> Recording:
        return Recording(contact_mobility=True, snapshot_every=500)

    def estimate(self, rollout: Rollout) -> Sensitivities:
        assert rollout.contact_mobility is not None and rollout.control_dt is not None
        assert rollout.replay is not None
        response = rollout.replay(0, 2, np.zeros((1, 7)))  # the world still holds the rollout
        assert response.shape == (1, 3) and np.all(np.isfinite(response))
        if self.seen is not None:
            self.seen.append(rollout)
        n = len(rollout)
        moved = np.any(np.diff(rollout.box_position, axis=0, prepend=rollout.box_position[:1]), 1)
        jac = np.zeros((n, 3, 7))
        jac[moved, 0, 0] = TOY_GAIN
        return Sensitivities(jac, None)


SEEN: list[Rollout] = []


class FinalDistance(SceneAveraged):
    """A pure-performance toy: 100 times the final distance to the goal, m."""

    name = "toy-final-distance"

    @classmethod
    def from_spec(cls, spec: ObjectiveSpec) -> FinalDistance:
        return cls(spec)  # no estimator: nothing beyond the trajectory is recorded

    def score(self, rollout: Rollout, goal: np.ndarray) -> ObjectiveTerms:
        distance = float(np.linalg.norm(rollout.box_position[-1] - goal))
        zeros = np.zeros(len(rollout))
        return ObjectiveTerms(
            free_energy=100.0 * distance,
            goal_error=100.0 * distance,
            confidence=0.0,
            final_distance=distance,
            goal_error_t=zeros,
            confidence_t=zeros,
            free_energy_t=zeros,
            jacobian_norm_t=zeros,
        )


@pytest.fixture
def toys():
    SEEN.clear()
    register_estimator("toy", MovingBoxEstimator.from_spec)  # the one registration line
    register_objective("toy-final-distance", FinalDistance.from_spec)
    try:
        yield
    finally:
        unregister_estimator("toy")
        unregister_objective("toy-final-distance")


@pytest.mark.slow
def test_a_toy_estimator_runs_through_the_env(toys):
    env = ToolDesignEnv(estimator="toy", info_series=True)
    try:
        env.reset(seed=0)
        _, reward, _, _, info = env.step(np.array([0.0, 1.5, 0.0]))
    finally:
        env.close()
    assert len(SEEN) == 1 and SEEN[0].trajectory is not None  # the simulator's own record
    box = info["box_trajectory"]
    moved = np.any(np.diff(box, axis=0, prepend=box[:1]), axis=1)
    assert 0 < moved.sum() < len(box)
    # One eigenvalue TOY_GAIN^2 where the box moved: c_t = 1/2 log(1 + gain^2 / eps).
    per_step = 0.5 * math.log1p(TOY_GAIN**2 / ObjectiveSpec().eps)
    assert info["confidence"] == pytest.approx(per_step * moved.sum(), rel=1e-12)
    np.testing.assert_allclose(info["confidence_t"][moved], per_step, rtol=1e-12)
    assert info["estimator"] == "toy"
    assert reward == pytest.approx(-(info["goal_error"] - info["confidence"]))


@pytest.mark.slow
def test_a_toy_objective_runs_through_the_env(toys):
    env = ToolDesignEnv(objective_kind="toy-final-distance")
    try:
        env.reset(seed=0)
        _, reward, _, _, info = env.step(np.zeros(3))
    finally:
        env.close()
    assert info["valid"] and 0.0 < info["final_distance"] < 2.0
    assert reward == -100.0 * info["final_distance"]


def test_the_names_are_known_to_the_spec_only_while_registered(toys):
    assert "toy" in estimator_names() and "toy-final-distance" in objective_names()
    spec = ObjectiveSpec(estimator="toy", kind="toy-final-distance")
    assert isinstance(make_estimator(spec), MovingBoxEstimator)
    assert isinstance(make_objective(spec), FinalDistance)
    assert make_objective(spec).recording == Recording()


@pytest.mark.slow
def test_the_harness_takes_a_registered_estimator_in_its_own_process(toys):
    # The harness's task settings read the same registry as the spec: a design run with the
    # serial executor scores with the toy (a process pool's workers would need the
    # registration at import, docs/architecture.md).
    from benchmarks.execution import TaskSettings, evaluate_batch, make_executor

    task = TaskSettings(estimator="toy", objective="toy-final-distance")
    with make_executor("serial") as executor:
        (row,) = evaluate_batch(executor, [np.zeros(3)], task)
    assert row["status"] == "ok" and row["free_energy"] == -(-100.0 * row["final_distance"])
    with pytest.raises(ValueError, match="estimator must be one of .*'toy'"):
        TaskSettings(estimator="magic")


def test_after_unregistering_the_spec_refuses_the_name():
    register_estimator("toy", MovingBoxEstimator.from_spec)
    unregister_estimator("toy")
    with pytest.raises(ValueError, match=r"estimator must be one of \('contact', 'trajectory'"):
        ObjectiveSpec(estimator="toy")


def test_a_name_is_registered_once(toys):
    with pytest.raises(ValueError, match="'toy' is registered already"):
        register_estimator("toy", MovingBoxEstimator.from_spec)
    with pytest.raises(ValueError, match="'free-energy' is registered already"):
        register_objective("free-energy", FinalDistance.from_spec)
    with pytest.raises(ValueError, match="'contact' is registered already"):
        register_estimator("contact", MovingBoxEstimator.from_spec)


@pytest.mark.parametrize(
    ("name", "factory", "error", "match"),
    [
        ("", MovingBoxEstimator.from_spec, ValueError, "non-empty string"),
        (" toy", MovingBoxEstimator.from_spec, ValueError, "non-empty string"),
        (3, MovingBoxEstimator.from_spec, ValueError, "non-empty string"),
        ("toy2", 42, TypeError, "needs a factory"),
        ("toy2", "no_colon_here", TypeError, "'module:attribute'"),
    ],
)
def test_registering_refuses_bad_names_and_factories(name, factory, error, match):
    with pytest.raises(error, match=match):
        register_estimator(name, factory)
    assert "toy2" not in estimator_names()


def test_the_built_ins_cannot_be_unregistered_and_unknown_names_are_named():
    with pytest.raises(ValueError, match="built-in estimator 'contact'"):
        unregister_estimator("contact")
    with pytest.raises(ValueError, match="built-in objective 'free-energy'"):
        unregister_objective("free-energy")
    with pytest.raises(ValueError, match="no estimator named 'nope'"):
        unregister_estimator("nope")


def test_a_factory_given_by_its_path_is_imported_on_first_use():
    register_estimator(
        "trajectory-again", "tooldesign_env.objective.trajectory:TrajectoryEstimator.from_spec"
    )
    try:
        estimator = make_estimator(ObjectiveSpec(estimator="trajectory-again", window=30))
        assert isinstance(estimator, TrajectoryEstimator) and estimator.window == 30
    finally:
        unregister_estimator("trajectory-again")


def test_an_estimator_that_does_not_declare_its_needs_is_refused():
    class Silent:
        name = "silent"

        def estimate(self, rollout: Rollout) -> Sensitivities:  # pragma: no cover - never run
            raise AssertionError

    register_estimator("silent", lambda spec: Silent())
    try:
        with pytest.raises(TypeError, match="must declare what it needs recorded"):
            make_estimator(ObjectiveSpec(estimator="silent"))
    finally:
        unregister_estimator("silent")


def test_an_objective_without_the_three_methods_is_refused():
    class Half:
        name = "half"
        recording = Recording()

        def score(self, rollout: Rollout, goal: np.ndarray) -> ObjectiveTerms:  # pragma: no cover
            raise AssertionError

    register_objective("half", lambda spec: Half())
    try:
        with pytest.raises(TypeError, match=r"the objective 'half' has no method scenes\(\)"):
            make_objective(ObjectiveSpec(kind="half"))
    finally:
        unregister_objective("half")
