"""F averaged over scenes (ObjectiveSpec.scene_samples): the offsets, the mean, bad input."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tooldesign_env import ObjectiveSpec, SceneSpec, ToolDesignEnv
from tooldesign_env.objective import mean_terms, scene_offsets

HOOK = (0.4, 1.4, 0.18)


def test_offsets_start_with_the_nominal_scene_and_are_common_random_numbers():
    spec = ObjectiveSpec(scene_samples=5, scene_jitter=(2e-3, 0.02), scene_seed=7)
    offsets = scene_offsets(spec)
    assert offsets.shape == (5, 3)
    assert np.all(offsets[0] == 0.0)
    # The same spec gives the same scenes for every design; more samples keep the first ones.
    np.testing.assert_array_equal(offsets, scene_offsets(spec))
    more = scene_offsets(replace(spec, scene_samples=9))
    np.testing.assert_array_equal(more[:5], offsets)
    # Another seed gives other scenes; zero jitter gives the nominal scene K times.
    assert not np.array_equal(scene_offsets(replace(spec, scene_seed=8)), offsets)
    assert np.all(scene_offsets(replace(spec, scene_jitter=(0.0, 0.0))) == 0.0)
    assert scene_offsets(ObjectiveSpec()).shape == (1, 3)


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"scene_samples": 0}, ValueError),
        ({"scene_samples": 65}, ValueError),
        ({"scene_samples": True}, TypeError),
        ({"scene_samples": 2.0}, TypeError),
        ({"scene_samples": "4"}, TypeError),
        ({"scene_seed": -1}, ValueError),
        ({"scene_seed": 2**40}, ValueError),
        ({"scene_seed": False}, TypeError),
        ({"scene_jitter": (-1e-3, 0.0)}, ValueError),
        ({"scene_jitter": (1e-3, 0.5)}, ValueError),
        ({"scene_jitter": (0.05, 0.0)}, ValueError),
        ({"scene_jitter": (math.nan, 0.0)}, ValueError),
        ({"scene_jitter": (1e-3,)}, ValueError),
        ({"scene_jitter": "ab"}, ValueError),
        ({"scene_jitter": (True, 0.0)}, TypeError),
    ],
)
def test_objective_spec_rejects_bad_scene_settings(kwargs, error):
    with pytest.raises(error, match="ObjectiveSpec.scene_"):
        ObjectiveSpec(**kwargs)


def test_mean_terms_needs_terms():
    with pytest.raises(ValueError, match="at least one"):
        mean_terms([])


@pytest.mark.slow
def test_build_rejects_a_bad_box_offset():
    from tooldesign_env import ToolSimulator, make_tool

    sim = ToolSimulator()
    try:
        with pytest.raises(ValueError, match="box_offset"):
            sim.build(make_tool(HOOK), box_offset=(math.nan, 0.0, 0.0))
    finally:
        sim.close()


def _each_scene_alone(spec: ObjectiveSpec, objective: ObjectiveSpec) -> list[dict]:
    """The step ``info`` of HOOK in each of ``spec``'s scenes, built as a scene of its own."""
    base = SceneSpec()
    infos = []
    for dx, dy, dyaw in scene_offsets(spec):
        x, y = base.box_position
        scene = replace(
            base, box_position=(x + float(dx), y + float(dy)), box_yaw=base.box_yaw + float(dyaw)
        )
        one = ToolDesignEnv(scene=scene, objective=objective)
        one.reset(seed=0)
        infos.append(one.step(HOOK)[4])
        one.close()
    return infos


@pytest.mark.slow
def test_f_is_the_mean_over_the_scenes_and_the_first_is_the_nominal_one():
    spec = ObjectiveSpec(scene_samples=3, scene_jitter=(1e-3, 1e-2), scene_seed=3)
    env = ToolDesignEnv(objective=spec)
    env.reset(seed=0)
    info = env.step(HOOK)[4]
    env.close()
    # The same three scenes, each built as a scene of its own with K = 1.
    single = _each_scene_alone(spec, ObjectiveSpec())
    for key in ("free_energy", "goal_error", "confidence", "final_distance"):
        assert info[key] == pytest.approx(np.mean([s[key] for s in single]), rel=1e-12), key
    assert info["free_energy_std"] == pytest.approx(
        np.std([s["free_energy"] for s in single], ddof=1), rel=1e-12
    )
    assert single[0]["free_energy_std"] == 0.0


@pytest.mark.slow
def test_an_invalid_design_has_no_spread_over_scenes():
    env = ToolDesignEnv(objective=ObjectiveSpec(scene_samples=4), bounds=[(-1e3, 1e3)] * 3)
    env.reset(seed=0)
    info = env.step((1e3, -1e3, 0.0))[4]  # folds into itself: cannot be built
    env.close()
    assert not info["valid"] and info["free_energy_std"] == 0.0


@pytest.mark.slow
@pytest.mark.parametrize(
    ("value", "error"), [(0, ValueError), (65, ValueError), (True, TypeError), (2.0, TypeError)]
)
def test_design_and_suite_configs_check_scene_samples(value, error):
    from benchmarks.design import DesignConfig
    from benchmarks.suites import SuiteConfig

    with pytest.raises(error, match="scene_samples"):
        DesignConfig(scene_samples=value)
    with pytest.raises(error, match="scene_samples"):
        SuiteConfig(name="s", scene_samples=value)


def test_scene_samples_reach_the_env_only_when_asked_for():
    from benchmarks.design import DesignConfig

    assert "scene_samples" not in dict(DesignConfig().task().env_kwargs)
    assert dict(DesignConfig(scene_samples=3).task().env_kwargs)["scene_samples"] == 3


@pytest.mark.slow
def test_a_run_stored_before_scene_samples_existed_is_resumed(tmp_path):
    # Older manifests have no scene_samples: they are compared as K = 1, the value they had.
    import json

    from benchmarks.design import DesignConfig, run_design
    from benchmarks.storage import ResumeError

    config = DesignConfig(optimizer="random", iterations=1, batch_size=2, executor="serial")
    out = tmp_path / "run"
    run_design(config, out, progress=False, video=False)
    manifest_path = out / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    del manifest["config"]["scene_samples"]
    manifest_path.write_text(json.dumps(manifest))
    grown = replace(config, iterations=2)
    run_design(grown, out, resume=True, progress=False, video=False)
    with pytest.raises(ResumeError, match="scene_samples: 1 -> 2"):
        run_design(replace(grown, scene_samples=2), out, resume=True, progress=False, video=False)


@pytest.mark.slow
def test_the_expected_goal_error_is_averaged_over_the_scenes_too():
    # The robust-design objective: the mean over masses, and with K > 1 over the K scenes.
    masses = (0.1, 0.5)
    spec = ObjectiveSpec(kind="expected-goal-error", expected_masses=masses, scene_samples=2)
    env = ToolDesignEnv(objective=spec)
    env.reset(seed=0)
    info = env.step(HOOK)[4]
    env.close()
    single = [i["goal_error"] for i in _each_scene_alone(spec, replace(spec, scene_samples=1))]
    assert info["goal_error"] == pytest.approx(np.mean(single), rel=1e-12)
    assert single[0] != single[1]
