"""A policy over many tasks through the executors (issue 36): same F as the RL env, bad input.

:func:`benchmarks.rl.evaluation.evaluate_policy_on_tasks` simulates on ``ToolDesign-v0`` in the
executor's workers what ``ToolDesignRL-v0`` simulates one env at a time: the rows must agree bit
for bit, on every executor.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchmarks.rl.evaluation import (
    CallablePolicy,
    RLTask,
    action_to_coefficients,
    evaluate_policy_on_tasks,
    load_designer,
    policy_actions,
)

TASKS = [
    RLTask(id="a", goal=(0.1284, 0.7914, 0.1), box_mass=0.3416, box_friction=0.4447),
    RLTask(id="b", goal=(-0.3, 1.2, 0.1), box_mass=0.1),
]


def pseudo_random(observation: np.ndarray) -> np.ndarray:
    """A user's policy: an action that depends on the task."""
    return np.tanh(np.array([observation[0] * 3, observation[1] - 1, observation[3]]))


def test_a_task_is_checked() -> None:
    assert TASKS[0].observation().tolist() == pytest.approx([0.1284, 0.7914, 0.1, 0.3416])
    assert TASKS[0].observation().dtype == np.float32
    with pytest.raises(ValueError, match="task id"):
        RLTask(id="", goal=(0, 1, 0.1), box_mass=0.1)
    with pytest.raises(ValueError, match="goal must be 3 finite"):
        RLTask(id="x", goal=(0, float("nan"), 0.1), box_mass=0.1)
    with pytest.raises(ValueError, match=r"box_mass must be a number of kg in \(0, 1000\], got 0"):
        RLTask(id="x", goal=(0, 1, 0.1), box_mass=0)
    with pytest.raises(ValueError, match="box_friction must be None"):
        RLTask(id="x", goal=(0, 1, 0.1), box_mass=0.1, box_friction=-1)


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"box_friction": True}, r"box_friction must be None .* in \[0, 10\], got True"),
        ({"box_friction": "0.4"}, r"box_friction must be .*got '0.4'"),
        ({"box_friction": 11.0}, r"box_friction must be .*\[0, 10\], got 11.0"),
        ({"box_mass": "0.5"}, r"box_mass must be a number of kg in \(0, 1000\], got '0.5'"),
        ({"box_mass": True}, r"box_mass must be .*got True"),
        ({"box_mass": 2000.0}, r"box_mass must be .*got 2000.0"),
        ({"box_mass": float("inf")}, r"box_mass must be .*got inf"),
        ({"goal": (0, 1, "0.1")}, r"goal must be 3 finite numbers"),
        ({"goal": (0, True, 0.1)}, r"goal must be 3 finite numbers"),
        ({"goal": 0.1}, r"goal must be 3 finite numbers \(m\), got 0.1"),
        ({"goal": (0, 1)}, r"goal must be 3 finite numbers"),
        ({"goal": (0, 3.0, 0.1)}, r"goal must lie in the workspace .*got \(0.0, 3.0, 0.1\)"),
        ({"goal": (0, 1, -0.1)}, r"goal must lie in the workspace"),
    ],
)
def test_a_task_refuses_bad_types_and_ranges_before_any_policy_runs(
    fields: dict[str, object], message: str
) -> None:
    task = {"id": "x", "goal": (0, 1, 0.1), "box_mass": 0.1, **fields}
    with pytest.raises(ValueError, match=message) as excinfo:
        RLTask(**task)  # type: ignore[arg-type]
    assert "task x:" in str(excinfo.value) and "\n" not in str(excinfo.value)
    with pytest.raises(TypeError, match="set must be a string"):
        RLTask(id="x", goal=(0, 1, 0.1), box_mass=0.1, set=3)  # type: ignore[arg-type]
    # NumPy numbers are numbers: a task built from an array is accepted as floats.
    goal = np.array([0, 1, 0.1])
    ok = RLTask(id="x", goal=goal, box_mass=np.float32(0.5), box_friction=np.int64(0))  # type: ignore[arg-type]
    assert ok.goal == (0.0, 1.0, 0.1) and ok.box_mass == 0.5 and ok.box_friction == 0.0


def test_load_designer_takes_a_callable_and_refuses_the_rest(tmp_path: Path) -> None:
    spec = f"{__name__}:pseudo_random"  # this module, as pytest imported it
    policy, info = load_designer(spec)
    assert info == {"kind": "callable", "name": spec}
    action, _ = policy.predict(TASKS[0].observation())
    assert action.dtype == np.float32 and action.shape == (3,)
    zip_file = tmp_path / "model.zip"
    zip_file.write_bytes(b"PK")
    for spec, kwargs, error, message in (
        (3, {}, TypeError, "policy must be a path"),
        ("", {}, ValueError, "policy must be a path"),
        ("no_colon_here", {}, ValueError, "'module:callable'"),
        ("no_such_module_x:f", {}, ValueError, "cannot import"),
        ("numpy:no_such_name", {}, ValueError, "has no 'no_such_name'"),
        ("numpy:pi", {}, TypeError, "is not callable"),
        (str(tmp_path / "missing.zip"), {}, FileNotFoundError, "no Stable-Baselines3"),
        (str(zip_file), {}, ValueError, "needs its algorithm"),
        (str(zip_file), {"algorithm": "ppo"}, ValueError, "unpickling"),
        (str(tmp_path / "missing.json"), {}, FileNotFoundError, "No such file"),
    ):
        with pytest.raises(error, match=message):
            load_designer(spec, **kwargs)  # type: ignore[arg-type]


def test_a_callables_actions_are_checked() -> None:
    obs = TASKS[0].observation()
    with pytest.raises(ValueError, match="must return 3 finite numbers"):
        CallablePolicy(lambda o: [0.0, 0.0]).predict(obs)
    with pytest.raises(ValueError, match="outside \\[-1, 1\\]"):
        CallablePolicy(lambda o: [2.0, 0.0, 0.0]).predict(obs)
    with pytest.raises(TypeError, match="must be callable"):
        CallablePolicy(3)  # type: ignore[arg-type]


def test_evaluate_refuses_bad_input() -> None:
    policy = CallablePolicy(pseudo_random)
    with pytest.raises(ValueError, match="at least one RLTask"):
        evaluate_policy_on_tasks(policy, [])
    with pytest.raises(TypeError, match="RLTask objects"):
        evaluate_policy_on_tasks(policy, [(0, 1, 0.1)])  # type: ignore[list-item]
    with pytest.raises(ValueError, match="executor must be one of"):
        evaluate_policy_on_tasks(policy, TASKS, executor="threads")
    with pytest.raises(TypeError, match="predict"):
        evaluate_policy_on_tasks(object(), TASKS)


@pytest.mark.slow
@pytest.mark.parametrize("executor", ["serial", "process"])
def test_the_executor_gives_the_rl_envs_f_bit_for_bit(executor: str) -> None:
    from benchmarks.rl.agents import EpisodeLog, make_env
    from tooldesign_env.specs import SceneSpec

    policy = CallablePolicy(pseudo_random)
    rows = evaluate_policy_on_tasks(policy, TASKS, executor=executor, workers=2)
    assert rows["task"].tolist() == ["a", "b"] and set(rows["status"]) <= {"ok", "invalid"}
    for task, (_, row) in zip(TASKS, rows.iterrows(), strict=True):
        scene = (
            SceneSpec() if task.box_friction is None else SceneSpec(box_friction=task.box_friction)
        )
        env = EpisodeLog(make_env(scene=scene))
        obs, _ = env.reset(options={"goal": task.goal, "box_mass": task.box_mass})
        action, _ = policy.predict(obs)
        env.step(action)
        record = env.records[-1]
        assert list(record.coefficients) == [row["c1"], row["c2"], row["c3"]]
        assert record.free_energy == row["free_energy"]
        assert (
            list(record.coefficients)
            == action_to_coefficients(action, env.unwrapped.coefficient_bounds).tolist()
        )
        env.close()


@pytest.mark.slow
def test_the_throughput_script_runs_with_tiny_arguments() -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "perf.speed.rl_policy_throughput",
            "--episodes",
            "2",
            "--workers",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=Path(__file__).resolve().parents[1],
    )
    assert done.returncode == 0, done.stderr
    assert "one ToolDesignRL-v0 env" in done.stdout
    assert "on process with 1 worker(s)" in done.stdout and "per core" in done.stdout
    assert "on dask with 1 worker(s)" in done.stdout or "dask: not installed" in done.stdout


def test_the_throughput_script_refuses_bad_arguments() -> None:
    from perf.speed import rl_policy_throughput

    with pytest.raises(SystemExit):
        rl_policy_throughput.parse_args(["--episodes", "0"])
    with pytest.raises(SystemExit):
        rl_policy_throughput.parse_args(["--executors", "threads"])


def test_actions_and_their_coefficients_are_checked() -> None:
    bounds = [[-1.5, 1.5], [-1.5, 1.5], [-0.5, 0.5]]
    assert action_to_coefficients([0, 0, 0], bounds).tolist() == [0.0, 0.0, 0.0]
    assert action_to_coefficients([1, -1, 1], bounds).tolist() == [1.5, -1.5, 0.5]
    with pytest.raises(ValueError, match="bounds must be \\(3, 2\\)"):
        action_to_coefficients([0, 0, 0], bounds[:2])
    with pytest.raises(ValueError, match="within \\[-1, 1\\]"):
        action_to_coefficients([0, 2, 0], bounds)
    with pytest.raises(TypeError, match="predict"):
        policy_actions(object(), TASKS)

    class TwoNumbers:
        def predict(
            self, observation: object, deterministic: bool = True
        ) -> tuple[list[float], None]:
            return [0.0, 0.0], None

    with pytest.raises(ValueError, match="for task a must be 3 finite numbers"):
        policy_actions(TwoNumbers(), TASKS)
    clipped = policy_actions(CallablePolicy(pseudo_random), TASKS)
    assert clipped.shape == (2, 3) and clipped.dtype == np.float32
