"""The options of issue 31, items 2 and 3: each refuses bad input, and the defaults are unchanged.

The defaults stay those of 062b3a0: the flip was measured and not taken (docs/performance.md, "The
flip: not taken"); the tests below that pin the defaults are the ones that would change with one.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tooldesign_env import ObjectiveSpec, SceneSpec
from tooldesign_env.objective.terms import Sensitivities, control_confidence
from tooldesign_env.specs import (
    DEFAULT_PHYSICS,
    LOWER_FLOOR,
    PHYSICS_062B3A0,
    PHYSICS_PRESETS,
    physics_preset,
)


def _jacobians(seed: int, steps: int = 200) -> np.ndarray:
    """(steps, 3, 7) Jacobians of the contact estimator's size (m/N m), a quarter of them zero."""
    rng = np.random.default_rng(seed)
    jac = rng.normal(scale=5e-3, size=(steps, 3, 7))
    jac[rng.random(steps) < 0.25] = 0.0
    # Rank 2, as when the box's z does not move.
    jac[: steps // 2, 2, :] = 0.0
    return jac


# ------------------------------------------------------------------ ObjectiveSpec.gram
@pytest.mark.parametrize("value", ["3x3", "", "Box", None, 3, ("box",)])
def test_gram_refuses_anything_but_joints_or_box(value):
    with pytest.raises(ValueError, match=r"ObjectiveSpec\.gram must be one of \('joints', 'box'\)"):
        ObjectiveSpec(gram=value)


def test_control_confidence_refuses_an_unknown_gram():
    sens = Sensitivities(_jacobians(0, 4), None)
    with pytest.raises(ValueError, match="gram must be 'joints' or 'box', got 'rows'"):
        control_confidence(sens, np.zeros((4, 3)), np.zeros(3), eps=1e-6, gram="rows")


@pytest.mark.parametrize("seed", range(3))
def test_the_3x3_gram_gives_the_same_confidence_up_to_rounding(seed):
    jac = _jacobians(seed)
    box = np.zeros((jac.shape[0], 3))
    goal = np.array([0.0, 1.5, 0.1])
    sens = Sensitivities(jac, None)
    joints = control_confidence(sens, box, goal, eps=1e-6, gram="joints")
    small = control_confidence(sens, box, goal, eps=1e-6, gram="box")
    assert np.all(joints[np.all(jac == 0, axis=(1, 2))] == 0)
    np.testing.assert_allclose(small, joints, rtol=1e-9, atol=1e-12)
    assert np.all(small[np.all(jac == 0, axis=(1, 2))] == 0)


def test_with_a_second_order_term_the_gram_option_changes_nothing():
    rng = np.random.default_rng(4)
    jac = _jacobians(4, 50)
    hess = rng.normal(scale=1e-4, size=(50, 3, 7, 7))
    box = rng.normal(size=(50, 3))
    goal = np.zeros(3)
    sens = Sensitivities(jac, hess)
    joints = control_confidence(sens, box, goal, eps=1e-6, form="clamped", gram="joints")
    small = control_confidence(sens, box, goal, eps=1e-6, form="clamped", gram="box")
    assert np.array_equal(joints, small)


def test_the_default_gram_is_the_7x7_of_every_committed_result():
    assert ObjectiveSpec().gram == "joints"
    jac = _jacobians(5)
    box, goal = np.zeros((jac.shape[0], 3)), np.zeros(3)
    sens = Sensitivities(jac, None)
    default = control_confidence(sens, box, goal, eps=1e-6)
    # The 7 x 7 J^T J, decomposed as before the option existed: bit for bit.
    pi = np.swapaxes(jac, -1, -2) @ jac
    nonzero = np.any(pi != 0.0, axis=(1, 2))
    sub = pi[nonzero]
    lam = np.linalg.eigvalsh(0.5 * (sub + np.swapaxes(sub, -1, -2)))
    expected = np.zeros(jac.shape[0])
    expected[nonzero] = 0.5 * np.sum(np.log1p(np.maximum(lam, 0.0) / 1e-6), axis=1)
    assert np.array_equal(default, expected)


# ------------------------------------------------------------------ the presets
def test_the_defaults_are_still_the_physics_of_062b3a0():
    assert DEFAULT_PHYSICS is PHYSICS_062B3A0
    scene, objective = SceneSpec(), ObjectiveSpec()
    assert (scene.solver_iterations, scene.rest_time) == (50, 0.1)
    assert objective.gram == "joints"
    assert PHYSICS_062B3A0.specs() == {"scene": scene, "objective": objective}


def test_the_lower_floor_preset_changes_only_its_fields():
    specs = LOWER_FLOOR.specs()
    changed = {
        f.name
        for f in dataclasses.fields(SceneSpec)
        if getattr(specs["scene"], f.name) != getattr(SceneSpec(), f.name)
    }
    assert changed == {"solver_iterations", "rest_time"}
    assert specs["objective"] == dataclasses.replace(ObjectiveSpec(), gram="box")
    # Fields a caller set stay set.
    mine = LOWER_FLOOR.specs(scene=SceneSpec(box_mass=0.5), objective=ObjectiveSpec(eps=1e-5))
    assert mine["scene"].box_mass == 0.5 and mine["scene"].solver_iterations == 20
    assert mine["objective"].eps == 1e-5 and mine["objective"].gram == "box"


def test_presets_are_found_by_name_and_an_unknown_name_is_refused():
    assert physics_preset("lower-floor") is LOWER_FLOOR
    assert set(PHYSICS_PRESETS) == {"062b3a0", "lower-floor"}
    for name in ("fast", "", None, 1):
        with pytest.raises(ValueError, match="the physics preset must be one of"):
            physics_preset(name)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("scene", "objective"),
    [(ObjectiveSpec(), None), (None, SceneSpec()), ({"solver_iterations": 20}, None)],
)
def test_a_preset_refuses_specs_of_the_wrong_kind(scene, objective):
    with pytest.raises(TypeError, match="must be a (SceneSpec|ObjectiveSpec) or None"):
        LOWER_FLOOR.specs(scene=scene, objective=objective)


def test_a_preset_with_a_bad_value_is_refused_by_the_spec_it_sets():
    bad = dataclasses.replace(LOWER_FLOOR, solver_iterations=0)
    with pytest.raises(ValueError, match="SceneSpec.solver_iterations"):
        bad.specs()
    with pytest.raises(ValueError, match=r"ObjectiveSpec\.gram"):
        dataclasses.replace(LOWER_FLOOR, gram="3x3").specs()


# ------------------------------------------------------------------ Python per control step
def test_the_tool_yaw_of_all_steps_at_once_has_the_bits_of_the_one_step_form():
    from tooldesign_env.rollout import tool_yaw as _tool_yaw
    from tooldesign_env.rollout import tool_yaws as _tool_yaws

    rng = np.random.default_rng(6)
    quaternions = rng.normal(size=(3000, 4))
    quaternions /= np.linalg.norm(quaternions, axis=1)[:, None]
    one_by_one = [_tool_yaw(tuple(row)) for row in quaternions.tolist()]
    assert _tool_yaws(quaternions) == one_by_one
    assert _tool_yaws(np.zeros((0, 4))) == []


# ------------------------------------------------------------------ the rule, on the preset
@pytest.mark.slow
def test_the_lower_floor_preset_passes_tests_1_and_2_of_the_equivalence_rule():
    """What would make a flip a proven one-line change: the preset is equivalent to the defaults.

    Test 3 (the smoke suites' verdicts) was run by hand for it (docs/performance.md); it needs
    the four smoke suites and cannot set the objective's ``gram`` from the command line.
    """
    from platforms import assert_equivalent

    from benchmarks.suites import equivalence as eq

    reference = eq.read_reference()
    assert_equivalent(eq.check(reference, changes=LOWER_FLOOR.specs(), workers=2), reference)
