"""The baselines on ``ToolDesignRL-v0``: PPO, SAC, a contextual regression, random sampling, CMA-ES.

Every method sees the same env and is charged one episode per tool it simulates; every episode
is logged (:class:`EpisodeLog`) with its task and its unscaled F, so methods are compared on F at
equal episodes. Stable-Baselines3 is imported only by the functions that need it (extra ``rl``):
without it, :func:`train_ppo` and :func:`train_sac` raise an ``ImportError`` that says how to
install it, and everything else works.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

import tooldesign_env  # noqa: F401  (registers ToolDesignRL-v0)
from benchmarks.rl.configs import ContextualConfig, PPOConfig, SACConfig
from optimizers import SEED_MAX
from tooldesign_env.rl import ToolDesignRLEnv
from tooldesign_env.schema import DEFAULT_BOX_MASS

__all__ = [
    "RL_EXTRA",
    "ContextualPolicy",
    "EpisodeLog",
    "EpisodeRecord",
    "evaluate_design",
    "import_sb3",
    "make_env",
    "run_cmaes",
    "run_random",
    "train_contextual",
    "train_ppo",
    "train_sac",
]

Progress = Callable[[str], None]

#: What to run when Stable-Baselines3 (or torch) is missing: the CPU build of torch first.
RL_EXTRA = 'pip install "torch==2.13.0" && pip install "tooldesign[rl]"'


@dataclass(frozen=True)
class EpisodeRecord:
    """One simulated tool.

    Attributes:
        goal: (x, y, z) in m.
        box_mass: kg.
        action: (3,) in [-1, 1].
        free_energy: F, unscaled.
        reward: the normalized reward 1 - F / F_idle.
        valid: whether the design could be used.
        final_distance: the box's final distance to the goal, m.
        coefficients: (3,) the tool's physical coefficients (c1, c2, c3).
        final_height: the box centre's final height, m (the task's success test asks it to
            stand: ``TaskDefinition.succeeded``); NaN where the env did not say.
        final_tilt: the angle of the box's up axis from the vertical at the end, rad; NaN
            where the env did not say.
        goal_error: the goal-error term of F.
        confidence: the control-confidence term of F.
        goal_precision: p^X of the objective, 1/m^2.
        seconds: wall time of the episode's step (the simulation), s.
    """

    goal: tuple[float, float, float]
    box_mass: float
    action: tuple[float, ...]
    free_energy: float
    reward: float
    valid: bool
    final_distance: float
    coefficients: tuple[float, ...] = ()
    goal_error: float = float("nan")
    confidence: float = float("nan")
    goal_precision: float = float("nan")
    seconds: float = float("nan")
    final_height: float = float("nan")
    final_tilt: float = float("nan")


class EpisodeLog(gym.Wrapper[np.ndarray, np.ndarray, np.ndarray, np.ndarray]):
    """Records every episode of the wrapped env, and scales the reward the agent sees.

    Args:
        env: a ``ToolDesignRL-v0`` env (normalized reward).
        reward_scale: factor on the reward returned to the agent; the log keeps F unscaled.
    """

    def __init__(self, env: gym.Env[np.ndarray, np.ndarray], reward_scale: float = 1.0) -> None:
        super().__init__(env)
        self.records: list[EpisodeRecord] = []
        self.reward_scale = float(reward_scale)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Step the env and log the episode."""
        started = time.perf_counter()
        obs, reward, terminated, truncated, info = self.env.step(action)
        seconds = time.perf_counter() - started
        base = getattr(self.env.unwrapped, "base", None)
        precision = float("nan") if base is None else float(base.objective.goal_precision)
        self.records.append(
            EpisodeRecord(
                goal=tuple(float(v) for v in info["goal"]),  # type: ignore[arg-type]
                box_mass=float(info["box_mass"]),
                action=tuple(float(v) for v in np.asarray(action).ravel()),
                free_energy=float(info["free_energy"]),
                reward=float(info["normalized_reward"]),
                valid=bool(info["valid"]),
                final_distance=float(info["final_distance"]),
                coefficients=tuple(float(c) for c in np.asarray(info["coefficients"]).ravel()),
                goal_error=float(info["goal_error"]),
                confidence=float(info["confidence"]),
                goal_precision=precision,
                seconds=seconds,
                final_height=float(info.get("final_height", float("nan"))),
                final_tilt=float(info.get("final_tilt", float("nan"))),
            )
        )
        return obs, float(reward) * self.reward_scale, terminated, truncated, info


def make_env(
    *, goal: Sequence[float] | None = None, randomize_goal: bool = False, **kwargs: Any
) -> ToolDesignRLEnv:
    """A ``ToolDesignRL-v0`` env at a fixed ``goal`` (the default goal if None) or random goals.

    The reward is the normalized one unless ``reward=`` says otherwise.
    """
    if goal is not None:
        kwargs["goal"] = tuple(goal)
    kwargs.setdefault("reward", "normalized")
    return ToolDesignRLEnv(randomize_goal=randomize_goal, **kwargs)


#: Most episodes of one run: each is a simulation (about 0.3 s) and a kept record, so 10^5 is
#: hours and about 100 MB (the rl suite's largest size spends 1,024); 10^20 hung.
EPISODES_MAX = 100_000


def _check_episodes(total_episodes: Any) -> int:
    if isinstance(total_episodes, bool) or not isinstance(total_episodes, (int, np.integer)):
        raise TypeError(
            f"total_episodes must be an int from 1 to {EPISODES_MAX}, got {total_episodes!r}"
        )
    if not 1 <= total_episodes <= EPISODES_MAX:
        raise ValueError(
            f"total_episodes must be an int from 1 to {EPISODES_MAX}, got {total_episodes!r}"
        )
    return int(total_episodes)


def _check_seed(seed: Any) -> int:
    # Seeds are stored as int64, as everywhere else (optimizers.SEED_MAX).
    if (
        isinstance(seed, bool)
        or not isinstance(seed, (int, np.integer))
        or not 0 <= seed <= SEED_MAX
    ):
        raise TypeError(f"seed must be an int from 0 to 2^63 - 1, got {seed!r}")
    return int(seed)


def import_sb3() -> Any:
    """The ``stable_baselines3`` module, or an ``ImportError`` that says how to install it."""
    try:
        import stable_baselines3
    except ImportError as error:
        raise ImportError(
            f"PPO and SAC need Stable-Baselines3 and torch, which are not installed ({error}); "
            f"install them with `{RL_EXTRA}`"
        ) from error
    return stable_baselines3


def _quiet_logger(model: Any) -> None:
    """Give ``model`` a logger that writes nothing.

    Without one, every ``learn()`` makes an empty ``SB3-<date>`` folder in the system's temporary
    folder (Stable-Baselines3's default logger, even with ``verbose=0``), which a suite of
    hundreds of trainings leaves behind. The records this module keeps are the episodes
    (:class:`EpisodeLog`), not SB3's training statistics.
    """
    from stable_baselines3.common.logger import Logger

    model.set_logger(Logger(folder=None, output_formats=[]))


def _torch_single_thread() -> None:
    import torch

    # The machine is shared; one thread is also the fastest for these tiny networks.
    torch.set_num_threads(1)


@dataclass
class Trained:
    """A trained agent and the episodes its training spent.

    Attributes:
        model: the Stable-Baselines3 model, or a :class:`ContextualPolicy`.
        records: every episode simulated in training, in order.
    """

    model: Any
    records: list[EpisodeRecord] = field(default_factory=list)


def train_ppo(
    config: PPOConfig,
    *,
    total_episodes: int,
    seed: int,
    goal: Sequence[float] | None = None,
    randomize_goal: bool = False,
    env_kwargs: dict[str, Any] | None = None,
) -> Trained:
    """Train PPO for ``total_episodes`` episodes at a fixed goal or on random goals.

    Args:
        config: the hyperparameters.
        total_episodes: episodes (= environment steps) to train for; PPO collects whole
            rollouts of ``config.n_steps``, so this is rounded up to a multiple of it.
        seed: seeds the agent and the env.
        goal: a fixed goal (x, y, z) in m; the default goal if None and not ``randomize_goal``.
        randomize_goal: draw each episode's goal from the paper's range.
        env_kwargs: more arguments of ``ToolDesignRL-v0``.

    Returns:
        The model and the episodes of its training.

    Raises:
        TypeError: ``config`` is not a :class:`PPOConfig`, or a bad ``total_episodes``/``seed``.
        ValueError: ``total_episodes`` < 1.
    """
    if not isinstance(config, PPOConfig):
        raise TypeError(f"config must be a PPOConfig, got {config!r}")
    total = _check_episodes(total_episodes)
    seed = _check_seed(seed)
    PPO = import_sb3().PPO
    _torch_single_thread()
    env = EpisodeLog(
        make_env(goal=goal, randomize_goal=randomize_goal, **(env_kwargs or {})),
        reward_scale=config.reward_scale,
    )
    model = PPO(
        "MlpPolicy",
        env,
        n_steps=config.n_steps,
        batch_size=config.batch_size,
        n_epochs=config.n_epochs,
        learning_rate=config.learning_rate,
        ent_coef=config.ent_coef,
        clip_range=config.clip_range,
        gamma=0.0,  # one-step episodes: the return is the reward
        gae_lambda=1.0,
        policy_kwargs={"log_std_init": config.log_std_init, "net_arch": list(config.net_arch)},
        seed=seed,
        device="cpu",
        verbose=0,
    )
    _quiet_logger(model)
    model.learn(total_timesteps=total)
    env.close()
    return Trained(model, env.records)


def train_sac(
    config: SACConfig,
    *,
    total_episodes: int,
    seed: int,
    goal: Sequence[float] | None = None,
    randomize_goal: bool = False,
    env_kwargs: dict[str, Any] | None = None,
) -> Trained:
    """Train SAC for ``total_episodes`` episodes at a fixed goal or on random goals.

    Args:
        config: the hyperparameters.
        total_episodes: episodes (= environment steps) to train for.
        seed: seeds the agent and the env.
        goal: a fixed goal (x, y, z) in m; the default goal if None and not ``randomize_goal``.
        randomize_goal: draw each episode's goal from the paper's range.
        env_kwargs: more arguments of ``ToolDesignRL-v0``.

    Returns:
        The model and the episodes of its training.

    Raises:
        TypeError: ``config`` is not a :class:`SACConfig`, or a bad ``total_episodes``/``seed``.
        ValueError: ``total_episodes`` < 1.
    """
    if not isinstance(config, SACConfig):
        raise TypeError(f"config must be a SACConfig, got {config!r}")
    total = _check_episodes(total_episodes)
    seed = _check_seed(seed)
    SAC = import_sb3().SAC
    _torch_single_thread()
    env = EpisodeLog(
        make_env(goal=goal, randomize_goal=randomize_goal, **(env_kwargs or {})),
        reward_scale=config.reward_scale,
    )
    model = SAC(
        "MlpPolicy",
        env,
        learning_starts=config.learning_starts,
        batch_size=config.batch_size,
        learning_rate=config.learning_rate,
        gradient_steps=config.gradient_steps,
        train_freq=1,
        ent_coef=config.ent_coef,
        gamma=0.0,  # one-step episodes
        buffer_size=max(total, 1),
        policy_kwargs={"net_arch": list(config.net_arch)},
        seed=seed,
        device="cpu",
        verbose=0,
    )
    _quiet_logger(model)
    model.learn(total_timesteps=total)
    env.close()
    return Trained(model, env.records)


def run_random(
    *,
    total_episodes: int,
    seed: int,
    goal: Sequence[float] | None = None,
    box_mass: float | None = None,
    env: ToolDesignRLEnv | None = None,
) -> list[EpisodeRecord]:
    """Random sampling: ``total_episodes`` designs uniform in the [-1, 1] action box at a task.

    Args:
        total_episodes: designs to simulate.
        seed: seeds the sampler.
        goal: (x, y, z) in m; the env's goal if None.
        box_mass: kg; the env's box mass if None.
        env: an env to reuse; a fresh one if None.

    Raises:
        TypeError / ValueError: bad ``total_episodes`` or ``seed``.
    """
    total = _check_episodes(total_episodes)
    rng = np.random.default_rng(_check_seed(seed))
    own = env is None
    logged = EpisodeLog(env if env is not None else make_env(goal=goal))
    options = _task_options(goal, box_mass)
    for _ in range(total):
        logged.reset(options=options)
        logged.step(rng.uniform(-1.0, 1.0, 3).astype(np.float32))
    if own:
        logged.close()
    return logged.records


def _task_options(goal: Sequence[float] | None, box_mass: float | None) -> dict[str, Any] | None:
    options: dict[str, Any] = {}
    if goal is not None:
        options["goal"] = tuple(goal)
    if box_mass is not None:
        options["box_mass"] = box_mass
    return options or None


def _run_generations(
    opt: Any, logged: EpisodeLog, options: dict[str, Any] | None, total: int
) -> None:
    """Simulate ``opt``'s generations, one episode each design, until ``total`` are logged.

    The last generation is cut short if needed (and not told). Shared by the cold CMA-ES and
    the warm-started one (:func:`benchmarks.rl.warmstart.run_warm_cmaes`).
    """
    while len(logged.records) < total:
        batch = opt.ask()
        values = []
        for x in batch.x:
            if len(logged.records) >= total:
                break
            logged.reset(options=options)
            logged.step(np.asarray(x, dtype=np.float32))
            values.append(logged.records[-1].free_energy)
        if len(values) < len(batch):
            break
        opt.tell(batch.ids, values)


def run_cmaes(
    *,
    total_episodes: int,
    seed: int,
    goal: Sequence[float] | None = None,
    box_mass: float | None = None,
    popsize: int = 8,
    sigma0: float = 0.3,
    env: ToolDesignRLEnv | None = None,
) -> list[EpisodeRecord]:
    """CMA-ES (``optimizers.make("cmaes")``) on F at one task, in the [-1, 1] action box.

    Runs whole generations until ``total_episodes`` designs are simulated (the last generation
    is cut short if needed; CMA-ES's behaviour does not depend on the budget, so the first n
    episodes of a long run are the run of budget n). ``goal`` (m) and ``box_mass`` (kg) are the
    env's if None.

    Raises:
        TypeError / ValueError: bad ``total_episodes`` or ``seed``.
    """
    import optimizers

    total = _check_episodes(total_episodes)
    seed = _check_seed(seed)
    own = env is None
    logged = EpisodeLog(env if env is not None else make_env(goal=goal))
    options = _task_options(goal, box_mass)
    opt = optimizers.make(
        "cmaes", bounds=[[-1.0, 1.0]] * 3, batch_size=popsize, seed=seed, sigma0=sigma0
    )
    _run_generations(opt, logged, options, total)
    if own:
        logged.close()
    return logged.records


class ContextualPolicy:
    """Task -> design: a kernel regression (or nearest neighbour) over per-task optima.

    The task is the goal, or the goal and the box mass when ``masses`` are given; the distance
    between two tasks is sqrt(|goal - goal'|^2 + (mass_scale (m - m'))^2) in m.

    Args:
        goals: (k, 3) training goals in m.
        actions: (k, 3) the best design found at each, in [-1, 1].
        bandwidth: Gaussian kernel width in m.
        mode: ``"kernel"`` or ``"nearest"``.
        masses: (k,) the training tasks' box masses in kg, or None for a goal-only policy.
        mass_scale: m of goal distance one kg of mass difference counts as, > 0.
    """

    def __init__(
        self,
        goals: Any,
        actions: Any,
        *,
        bandwidth: float = 0.25,
        mode: str = "kernel",
        masses: Any = None,
        mass_scale: float = 1.0,
    ) -> None:
        self.goals = np.asarray(goals, dtype=float).reshape(-1, 3)
        self.actions = np.asarray(actions, dtype=float).reshape(-1, 3)
        if len(self.goals) != len(self.actions) or len(self.goals) == 0:
            raise ValueError("goals and actions must be equally many (k >= 1) rows of 3")
        if not (np.all(np.isfinite(self.goals)) and np.all(np.abs(self.actions) <= 1.0)):
            raise ValueError("goals must be finite and actions within [-1, 1]")
        if mode not in ("kernel", "nearest"):
            raise ValueError(f"mode must be 'kernel' or 'nearest', got {mode!r}")
        if not (isinstance(bandwidth, (int, float)) and math.isfinite(bandwidth) and bandwidth > 0):
            raise ValueError(f"bandwidth must be a finite number > 0 (m), got {bandwidth!r}")
        if not (
            isinstance(mass_scale, (int, float)) and math.isfinite(mass_scale) and mass_scale > 0
        ):
            raise ValueError(f"mass_scale must be a finite number > 0 (m/kg), got {mass_scale!r}")
        self.masses: np.ndarray | None = None
        if masses is not None:
            self.masses = np.asarray(masses, dtype=float).ravel()
            if len(self.masses) != len(self.goals) or not np.all(self.masses > 0):
                raise ValueError(
                    f"masses must be {len(self.goals)} box masses > 0 kg, one per goal, "
                    f"got {masses!r}"
                )
        self.bandwidth = float(bandwidth)
        self.mode = mode
        self.mass_scale = float(mass_scale)

    def predict(self, observation: Any, deterministic: bool = True) -> tuple[np.ndarray, None]:
        """The design (3,) float32 in [-1, 1] for an observation (x, y, z[, box mass]).

        Same call shape as a Stable-Baselines3 model's ``predict``. A policy trained with masses
        needs the box mass (kg) in the observation.
        """
        obs = np.asarray(observation, dtype=float).ravel()
        goal = obs[:3]
        d2 = np.sum((self.goals - goal) ** 2, axis=1)
        if self.masses is not None:
            if obs.size < 4:
                raise ValueError(
                    "this policy was trained on box masses: the observation must be "
                    f"(x, y, z, box mass), got {observation!r}"
                )
            d2 = d2 + (self.mass_scale * (self.masses - obs[3])) ** 2
        if self.mode == "nearest":
            action = self.actions[int(np.argmin(d2))]
        else:
            logw = -d2 / (2.0 * self.bandwidth**2)
            w = np.exp(logw - logw.max())
            action = (w[:, None] * self.actions).sum(0) / w.sum()
        return np.clip(action, -1.0, 1.0).astype(np.float32), None

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready description (the saved policy)."""
        data: dict[str, Any] = {
            "goals": self.goals.tolist(),
            "actions": self.actions.tolist(),
            "bandwidth": self.bandwidth,
            "mode": self.mode,
        }
        if self.masses is not None:
            data.update(masses=self.masses.tolist(), mass_scale=self.mass_scale)
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ContextualPolicy:
        """The inverse of :meth:`to_dict` (a card without masses is a goal-only policy)."""
        return cls(
            data["goals"],
            data["actions"],
            bandwidth=data["bandwidth"],
            mode=data["mode"],
            masses=data.get("masses"),
            mass_scale=data.get("mass_scale", 1.0),
        )


def train_contextual(
    config: ContextualConfig,
    *,
    seed: int,
    env_kwargs: dict[str, Any] | None = None,
    progress: Progress | None = None,
) -> Trained:
    """CMA-ES afresh on ``config.n_goals`` random tasks, then the task -> design regression.

    Goals are drawn uniformly from the paper's range by a generator seeded with ``seed``; with
    ``env_kwargs={"mass_range": (low, high)}`` each task also gets a box mass drawn uniformly
    from that range (after the goals, from the same generator, so the goals stay the same) and
    the policy regresses on goal and mass.

    Returns:
        The :class:`ContextualPolicy` and every episode of the CMA-ES runs.

    Raises:
        TypeError: ``config`` is not a :class:`ContextualConfig`, or a bad ``seed``.
    """
    if not isinstance(config, ContextualConfig):
        raise TypeError(f"config must be a ContextualConfig, got {config!r}")
    seed = _check_seed(seed)
    # Its training goals come from the env's goal_range, which the env takes only with
    # randomize_goal=True; each episode's goal is then given at reset, so nothing is drawn.
    env = make_env(**{"randomize_goal": True, **(env_kwargs or {})})
    low, high = env.goal_range
    children = np.random.SeedSequence(seed).spawn(config.n_goals + 1)
    rng = np.random.default_rng(children[0])
    goals = rng.uniform(low, high, size=(config.n_goals, 3))
    masses = None if env.mass_range is None else rng.uniform(*env.mass_range, config.n_goals)
    records: list[EpisodeRecord] = []
    best = []
    for k, goal in enumerate(goals):
        run = run_cmaes(
            total_episodes=config.episodes_per_goal,
            seed=int(children[k + 1].generate_state(1)[0]),
            goal=goal,
            box_mass=None if masses is None else float(masses[k]),
            popsize=config.popsize,
            sigma0=config.sigma0,
            env=env,
        )
        records.extend(run)
        top = min(run, key=lambda r: r.free_energy)
        best.append(top.action)
        if progress is not None:
            progress(f"contextual: task {k + 1}/{config.n_goals} best F {top.free_energy:.0f}")
    env.close()
    policy = ContextualPolicy(
        goals,
        best,
        bandwidth=config.bandwidth,
        mode=config.mode,
        masses=masses,
        mass_scale=config.mass_scale,
    )
    return Trained(policy, records)


def evaluate_design(
    policy: Any,
    goal: Sequence[float],
    *,
    env: ToolDesignRLEnv | None = None,
    box_mass: float = DEFAULT_BOX_MASS,
) -> EpisodeRecord:
    """Simulate the policy's deterministic (zero-shot) design for ``goal``: one episode.

    Args:
        policy: a Stable-Baselines3 model or :class:`ContextualPolicy`.
        goal: (x, y, z) in m.
        env: an env to reuse; a fresh one if None.
        box_mass: the box mass in kg.
    """
    if not hasattr(policy, "predict"):
        raise TypeError(f"policy must have a predict(observation) method, got {policy!r}")
    own = env is None
    logged = EpisodeLog(env if env is not None else make_env())
    obs, _ = logged.reset(options={"goal": tuple(goal), "box_mass": box_mass})
    action, _ = policy.predict(obs, deterministic=True)
    logged.step(np.clip(np.asarray(action, dtype=np.float32).ravel(), -1.0, 1.0))
    if own:
        logged.close()
    return logged.records[-1]
