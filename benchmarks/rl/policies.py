"""Saved policies: write a trained baseline to disk, and design a tool for a new goal with it.

A saved policy is a small JSON card (``<name>.json``) naming the method, the training budget, the
configuration and, for PPO and SAC, the network's weights beside it; the contextual regression is
stored in the card itself (no torch needed to use it). The card also records the task it was
trained on: the tool's section and the arm (``section_shape``, ``merge_fixed_links``), which the
env it designs with is built with, and the ranges of its training goals and box masses
(``goal_range``, ``mass_range``), outside which designing warns.

**A policy file is data, never code.** PPO's and SAC's weights are a state dict in safetensors
(``<name>.safetensors``: named tensors, nothing to unpickle) whose SHA-256 the card records
(``weights_sha256``) and which is checked before the weights are parsed; the network is rebuilt
from the card's ``architecture`` (layer sizes, an activation from a fixed list, the observation and
action boxes), never from a class name in the file. The weights must be a regular file in the
card's folder (no path, no ``..``, no link). Cards of format 1 name a Stable-Baselines3 ``.zip``
instead, which Stable-Baselines3 loads by unpickling, so it can run any code: such a card is
loaded only with ``allow_pickle=True`` (``--allow-pickle``), with a warning, and
:func:`convert_policy` turns it into a card of this format once.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.rl.agents import ContextualPolicy, EpisodeLog, make_env
from benchmarks.rl.configs import MethodConfig
from benchmarks.storage import atomic_write_bytes, atomic_write_text, json_text
from tooldesign_env.schema import DEFAULT_BOX_MASS

__all__ = [
    "CARD_ADDED_FIELDS",
    "MAX_POLICY_PARAMETERS",
    "POLICY_FORMAT",
    "UnsafePolicyError",
    "convert_policy",
    "DesignResult",
    "design_for_goal",
    "load_policy",
    "policy_digest",
    "policy_env_kwargs",
    "policy_shapes",
    "read_policy_card",
    "save_policy",
]

#: Version of the card format written: 2 stores PPO's and SAC's weights in safetensors; 1 (read
#: only with ``allow_pickle``) named a Stable-Baselines3 ``.zip``.
POLICY_FORMAT = 2
_FORMATS = (1, 2)
_METHODS = ("ppo", "sac", "contextual")
_WEIGHTS_SUFFIX = ".safetensors"
#: The activations a card may name (looked up in this table, never imported by name).
_ACTIVATIONS = ("Tanh", "ReLU", "ELU", "LeakyReLU", "GELU", "SiLU")
_MAX_POLICY_BYTES = 256 << 20  # the committed SAC weights are 0.2 MB


class UnsafePolicyError(ValueError):
    """A policy file that would run code or read outside its card's folder, refused."""


#: Card fields added after the first cards were written, with the value those cards were trained
#: with: the committed rl suite (docs/results/square/rl, commit a327f7f) ran with the square
#: section and the 13-link arm, the defaults then. A card without a field is read with this value.
CARD_ADDED_FIELDS: dict[str, Any] = {"section_shape": "square", "merge_fixed_links": False}

#: The fields of a contextual card's ``policy`` (:meth:`ContextualPolicy.to_dict`).
_CONTEXTUAL_FIELDS = ("goals", "actions", "bandwidth", "mode")


@dataclass(frozen=True)
class DesignResult:
    """A tool designed by a saved policy for one goal.

    Attributes:
        goal: (x, y, z) in m.
        box_mass: kg.
        action: (3,) the policy's action in [-1, 1].
        coefficients: (3,) the tool's coefficients (c1, c2, c3).
        free_energy: F of the tool at the goal (NaN if not simulated).
        normalized_reward: 1 - F / F_idle (NaN if not simulated).
        final_distance: the box's final distance to the goal, m (NaN if not simulated).
        valid: whether the design could be used (None if not simulated).
    """

    goal: tuple[float, float, float]
    box_mass: float
    action: tuple[float, ...]
    coefficients: tuple[float, ...]
    free_energy: float
    normalized_reward: float
    final_distance: float
    valid: bool | None


def save_policy(
    model: Any,
    method: str,
    path: str | os.PathLike[str],
    *,
    config: MethodConfig,
    train_episodes: int,
    section_shape: str | None = None,
    merge_fixed_links: bool | None = None,
    goal_range: tuple[Sequence[float], Sequence[float]] | None = None,
    mass_range: Sequence[float] | None = None,
    extra: dict[str, Any] | None = None,
) -> Path:
    """Save a trained baseline as ``path`` (a ``.json`` card, plus ``.safetensors`` for PPO/SAC).

    Args:
        model: a Stable-Baselines3 PPO/SAC model or a :class:`ContextualPolicy`.
        method: ``"ppo"``, ``"sac"`` or ``"contextual"``.
        path: the card's path; must end in ``.json``.
        config: the configuration it was trained with.
        train_episodes: episodes its training spent.
        section_shape: the tool's section it was trained with (default: ``ToolSpec``'s).
        merge_fixed_links: the ``SceneSpec`` field it was trained with (default: today's).
        goal_range: (low, high), the (x, y, z) corners (m) of its training goals; designing
            outside warns. None records no range (and nothing warns).
        mass_range: (low, high), its training box masses (kg); likewise.
        extra: more JSON-ready fields for the card (seed, suite size, ...).

    Returns:
        The card's path.

    Raises:
        ValueError: an unknown method, or a path not ending in ``.json``.
        TypeError: a model that does not fit the method.
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {_METHODS}, got {method!r}")
    card_path = Path(path)
    if card_path.suffix != ".json":
        raise ValueError(f"path must end in .json (the policy card), got {str(path)!r}")
    from tooldesign_env.geometry import ToolSpec
    from tooldesign_env.specs import SceneSpec

    settings: dict[str, Any] = {
        "section_shape": ToolSpec().section_shape if section_shape is None else section_shape,
        "merge_fixed_links": SceneSpec().merge_fixed_links
        if merge_fixed_links is None
        else merge_fixed_links,
    }
    if goal_range is not None:
        settings["goal_range"] = [[float(v) for v in corner] for corner in goal_range]
    if mass_range is not None:
        settings["mass_range"] = [float(v) for v in mass_range]
    _check_settings(settings, card_path)
    card: dict[str, Any] = {
        "format": POLICY_FORMAT,
        "method": method,
        "env_id": "ToolDesignRL-v0",
        "train_episodes": int(train_episodes),
        "config": dataclasses.asdict(config),
        **(extra or {}),
        **settings,
    }
    if method == "contextual":
        if not isinstance(model, ContextualPolicy):
            raise TypeError(f"a contextual policy must be a ContextualPolicy, got {model!r}")
        card["policy"] = model.to_dict()
    else:
        if not hasattr(model, "policy") or not hasattr(model.policy, "state_dict"):
            raise TypeError(f"a {method} policy must be a Stable-Baselines3 model, got {model!r}")
        card.update(_weights_fields(model.policy, method, card_path))
    return atomic_write_text(card_path, json_text(card))


def _import_safetensors() -> Any:
    """The ``safetensors.torch`` module, or an ``ImportError`` naming the extra to install."""
    try:
        import safetensors.torch
    except ImportError as error:
        from benchmarks.rl.agents import RL_EXTRA

        raise ImportError(
            f"PPO and SAC policies are stored with safetensors, which is not installed "
            f"({error}); install it with `{RL_EXTRA}`"
        ) from error
    return safetensors.torch


def _weights_fields(policy: Any, method: str, card_path: Path) -> dict[str, Any]:
    """Write the policy's weights beside the card (safetensors); the card's fields naming them."""
    save = _import_safetensors().save

    architecture = _architecture(policy, method)
    state = {k: v.detach().cpu().contiguous() for k, v in policy.state_dict().items()}
    data = save(state)
    weights = card_path.with_suffix(_WEIGHTS_SUFFIX)
    atomic_write_bytes(weights, data)
    return {
        "weights": weights.name,
        "weights_sha256": hashlib.sha256(data).hexdigest(),
        "architecture": architecture,
    }


def _architecture(policy: Any, method: str) -> dict[str, Any]:
    """What rebuilds ``policy``'s network: sizes, activation, spaces (JSON, no class names)."""
    params = policy._get_constructor_parameters()
    activation = params["activation_fn"].__name__
    if activation not in _ACTIVATIONS:
        raise ValueError(f"the activation {activation} cannot be saved; use one of {_ACTIVATIONS}")
    if params.get("use_sde"):
        raise ValueError("a policy with gSDE exploration (use_sde=True) cannot be saved")
    extractor = params["features_extractor_class"].__name__
    if extractor != "FlattenExtractor":
        raise ValueError(f"a policy with the features extractor {extractor} cannot be saved")
    architecture: dict[str, Any] = {
        "net_arch": params["net_arch"],
        "activation_fn": activation,
        "observation_space": _box_fields(params["observation_space"]),
        "action_space": _box_fields(params["action_space"]),
        "log_std_init": float(params["log_std_init"]),
    }
    if method == "sac":
        architecture["n_critics"] = int(params["n_critics"])
        architecture["clip_mean"] = float(params["clip_mean"])
        architecture["share_features_extractor"] = bool(
            params.get("share_features_extractor", False)
        )
    else:
        architecture["share_features_extractor"] = bool(
            params.get("share_features_extractor", True)
        )
    return architecture


def _box_fields(space: Any) -> dict[str, Any]:
    low, high = np.asarray(space.low, dtype=float), np.asarray(space.high, dtype=float)
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
        raise ValueError(f"a policy over the unbounded space {space} cannot be saved")
    return {"low": low.ravel().tolist(), "high": high.ravel().tolist(), "shape": list(space.shape)}


def policy_digest(path: str | os.PathLike[str]) -> str:
    """SHA-256 of a saved policy: its card and, for PPO and SAC, the weights (or ``.zip``) it names.

    A design run made with a policy records it, so that resuming with a changed policy is
    refused instead of mixing two policies' designs. Nothing is loaded (no torch, no pickle).

    Raises:
        FileNotFoundError: no such card (or the file it names is missing).
        ValueError: not a policy card of a known format, or the file it names is not a regular
            file beside it (a path, ``..`` or a link: :class:`UnsafePolicyError`).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {path!r}")
    return _read_policy(Path(path))[0]


def read_policy_card(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The checked card of a saved policy, without loading its model (no torch).

    A card written before a field of :data:`CARD_ADDED_FIELDS` reads with that field's value.

    Raises:
        FileNotFoundError: no such card.
        ValueError / TypeError: not a policy card, or a field of the wrong value or type; the
            message names the card and the field.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {path!r}")
    card_path = Path(path)
    return _parse_card(card_path, _read_card_bytes(card_path))


def _read_card_bytes(card_path: Path) -> bytes:
    """The card's bytes: a regular file (the path the user gave may be a link to one)."""
    from benchmarks.storage import UnsafeRunFileError, read_run_file

    try:
        return read_run_file(
            card_path.resolve().parent, card_path.resolve().name, max_bytes=_MAX_POLICY_BYTES
        )
    except UnsafeRunFileError as err:
        raise UnsafePolicyError(f"{card_path} is not a policy card: {err}") from None
    except FileNotFoundError:
        raise FileNotFoundError(f"No such file: {card_path}") from None


def _read_policy(card_path: Path) -> tuple[str, dict[str, Any], bytes | None]:
    """``(digest, card, bytes of the file the card names or None)``, each file read once.

    The file a card names must be a regular file in the card's folder: a name, not a path.
    """
    from benchmarks.storage import UnsafeRunFileError, read_run_file

    data = _read_card_bytes(card_path)
    card = _parse_card(card_path, data)
    digest = hashlib.sha256(data)
    name = card.get("weights", card.get("file"))
    payload = None
    if name is not None:
        folder = card_path.resolve().parent
        if "/" in name or "\\" in name or name in (".", ".."):
            raise UnsafePolicyError(
                f"{card_path}: {name!r} is a path; a card names a file beside it in its own "
                f"folder ({folder}), and nothing outside that folder is read"
            )
        try:
            payload = read_run_file(folder, name, max_bytes=_MAX_POLICY_BYTES)
        except FileNotFoundError:
            raise FileNotFoundError(
                f"{card_path} names {folder / name}, which does not exist"
            ) from None
        except UnsafeRunFileError as err:
            raise UnsafePolicyError(f"{card_path} names a file that is refused: {err}") from None
        digest.update(payload)
    return digest.hexdigest(), card, payload


def _parse_card(card_path: Path, data: bytes) -> dict[str, Any]:
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(f"{card_path} is not a policy card (not UTF-8 text: {error})") from None
    try:
        card = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as error:
        raise ValueError(f"{card_path} is not a policy card (invalid JSON: {error})") from None
    if not isinstance(card, dict) or card.get("format") not in _FORMATS:
        raise ValueError(
            f"{card_path} is not a policy card of format {' or '.join(map(str, _FORMATS))}"
        )
    method = card.get("method")
    if method not in _METHODS:
        raise ValueError(f"{card_path}: 'method' must be one of {_METHODS}, got {method!r}")
    if method == "contextual":
        if "policy" not in card:
            raise ValueError(
                f"{card_path}: a contextual card holds its regression in the field 'policy', "
                "which is missing"
            )
        policy = card["policy"]
        if not isinstance(policy, dict):
            raise TypeError(
                f"{card_path}: 'policy' must be an object with the fields "
                f"{', '.join(_CONTEXTUAL_FIELDS)}, got {policy!r}"
            )
        missing = [name for name in _CONTEXTUAL_FIELDS if name not in policy]
        if missing:
            raise ValueError(f"{card_path}: 'policy' lacks the fields {', '.join(missing)}")
    elif card["format"] == 1:
        if "weights" in card:
            # A format-1 card is loaded from its .zip: weights named in it would be loaded
            # unchecked (the fields of format 2 are checked only there).
            raise ValueError(
                f"{card_path}: a card of format 1 names a Stable-Baselines3 .zip in 'file'; "
                "'weights' belongs to a card of format 2"
            )
        if "file" not in card:
            raise ValueError(
                f"{card_path}: a {method} card names its Stable-Baselines3 model in the field "
                "'file', which is missing"
            )
        if not isinstance(card["file"], str):
            raise TypeError(
                f"{card_path}: 'file' must be the name of the .zip beside the card, "
                f"got {card['file']!r}"
            )
        if not card["file"]:
            raise ValueError(f"{card_path}: 'file' must name the .zip beside the card, got ''")
    else:
        _check_weights_fields(card, card_path, method)
    card = {**CARD_ADDED_FIELDS, **card}
    _check_settings(card, card_path)
    return card


def _check_weights_fields(card: dict[str, Any], card_path: Path, method: str) -> None:
    """A format-2 PPO or SAC card: ``weights``, ``weights_sha256`` and ``architecture``."""
    weights = card.get("weights")
    if not isinstance(weights, str) or not weights.endswith(_WEIGHTS_SUFFIX):
        raise ValueError(
            f"{card_path}: a {method} card names its weights in the field 'weights', the name "
            f"of a {_WEIGHTS_SUFFIX} file beside it; got {weights!r}"
        )
    if "file" in card:
        raise ValueError(f"{card_path}: a card of format 2 has 'weights', not 'file'")
    digest = card.get("weights_sha256")
    if not (
        isinstance(digest, str) and len(digest) == 64 and set(digest) <= set("0123456789abcdef")
    ):
        raise ValueError(
            f"{card_path}: 'weights_sha256' must be the 64 hex digits of the weights' SHA-256, "
            f"got {digest!r}"
        )
    architecture = card.get("architecture")
    if not isinstance(architecture, dict):
        raise TypeError(f"{card_path}: 'architecture' must be an object, got {architecture!r}")
    activation = architecture.get("activation_fn")
    if activation not in _ACTIVATIONS:
        raise ValueError(
            f"{card_path}: 'architecture.activation_fn' must be one of {_ACTIVATIONS}, "
            f"got {activation!r}"
        )
    net_arch = architecture.get("net_arch")
    layers = list(net_arch.values()) if isinstance(net_arch, dict) else [net_arch]
    if (
        not layers
        or not all(
            isinstance(sizes, list) and all(type(n) is int and 0 < n <= 65536 for n in sizes)
            for sizes in layers
        )
        or (isinstance(net_arch, dict) and not set(net_arch) <= {"pi", "vf", "qf"})
    ):
        raise ValueError(
            f"{card_path}: 'architecture.net_arch' must be a list of layer sizes (or an object "
            f"of lists pi, vf, qf), got {net_arch!r}"
        )
    for name in ("observation_space", "action_space"):
        box = architecture.get(name)
        if not (
            isinstance(box, dict)
            and isinstance(box.get("shape"), list)
            and len(box["shape"]) == 1
            and type(box["shape"][0]) is int
            and 0 < box["shape"][0] <= 1024
        ):
            raise ValueError(
                f"{card_path}: 'architecture.{name}' must be an object with 'shape' [n], "
                f"'low' and 'high', got {box!r}"
            )
        _check_pairs(
            [box.get("low"), box.get("high")],
            card_path,
            f"architecture.{name}",
            "low and high lists of finite numbers",
        )
        if len(box["low"]) != box["shape"][0]:
            raise ValueError(
                f"{card_path}: 'architecture.{name}' has low and high of another shape"
            )
    for name in ("log_std_init", "clip_mean"):
        value = architecture.get(name, 0.0)
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise ValueError(
                f"{card_path}: 'architecture.{name}' must be a finite number, got {value!r}"
            )
    if method == "sac":
        n = architecture.get("n_critics", 2)
        if type(n) is not int or not 1 <= n <= 16:
            raise ValueError(f"{card_path}: 'architecture.n_critics' must be 1-16, got {n!r}")
        if isinstance(net_arch, dict) and not {"pi", "qf"} <= set(net_arch):
            raise ValueError(
                f"{card_path}: 'architecture.net_arch' of a sac card is a list of layer sizes or "
                f"an object with pi and qf, got {net_arch!r}"
            )
    if not isinstance(architecture.get("share_features_extractor", False), bool):
        raise ValueError(
            f"{card_path}: 'architecture.share_features_extractor' must be true or false"
        )
    count = sum(math.prod(shape) for shape in policy_shapes(card).values())
    if count > MAX_POLICY_PARAMETERS:
        raise ValueError(
            f"{card_path}: 'architecture' makes a network of {count:,} parameters, more than the "
            f"{MAX_POLICY_PARAMETERS:,} a policy card may have"
        )


MAX_POLICY_PARAMETERS = 16_000_000
"""The most parameters a policy card's network may have (64 MB of float32); the committed
policies have some 10,000. Checked on the card's JSON, before its weights are read."""


def policy_shapes(card: Mapping[str, Any]) -> dict[str, tuple[int, ...]]:
    """The tensors, by name and shape, of the network a PPO or SAC card of format 2 describes.

    What Stable-Baselines3's ``ActorCriticPolicy`` (PPO) or ``SACPolicy`` builds from the card's
    ``architecture`` (an MLP feature-less policy: Flatten, then the layers of ``net_arch``),
    computed from the numbers alone: the weights' header is compared with it before any
    network is built, and the parameter count is bounded with it.
    """
    arch = card["architecture"]
    n_obs = int(arch["observation_space"]["shape"][0])
    n_act = int(arch["action_space"]["shape"][0])
    net_arch = arch["net_arch"]
    shapes: dict[str, tuple[int, ...]] = {}

    def mlp(prefix: str, n_in: int, sizes: Sequence[int], n_out: int | None = None) -> int:
        for i, size in enumerate(sizes):
            shapes[f"{prefix}.{2 * i}.weight"] = (size, n_in)
            shapes[f"{prefix}.{2 * i}.bias"] = (size,)
            n_in = size
        if n_out is not None:
            index = 2 * len(sizes)
            shapes[f"{prefix}.{index}.weight"] = (n_out, n_in)
            shapes[f"{prefix}.{index}.bias"] = (n_out,)
        return n_in

    if card["method"] == "sac":
        pi, qf = (net_arch["pi"], net_arch["qf"]) if isinstance(net_arch, dict) else (net_arch,) * 2
        last = mlp("actor.latent_pi", n_obs, pi)
        for head in ("mu", "log_std"):
            shapes[f"actor.{head}.weight"] = (n_act, last)
            shapes[f"actor.{head}.bias"] = (n_act,)
        for critic in ("critic", "critic_target"):
            for k in range(int(arch.get("n_critics", 2))):
                mlp(f"{critic}.qf{k}", n_obs + n_act, qf, 1)
        return shapes
    if isinstance(net_arch, dict):
        pi, vf = net_arch.get("pi", []), net_arch.get("vf", [])
    else:
        pi = vf = net_arch
    shapes["log_std"] = (n_act,)
    last_pi = mlp("mlp_extractor.policy_net", n_obs, pi)
    last_vf = mlp("mlp_extractor.value_net", n_obs, vf)
    shapes["action_net.weight"], shapes["action_net.bias"] = (n_act, last_pi), (n_act,)
    shapes["value_net.weight"], shapes["value_net.bias"] = (1, last_vf), (1,)
    return shapes


_MAX_HEADER_BYTES = 100 << 20  # safetensors' own limit


def _header_shapes(payload: bytes, card_path: Path, name: str) -> dict[str, tuple[int, ...]]:
    """The tensors' names and shapes in a safetensors file's header, the tensors not read.

    The header is 8 bytes of its length (little endian), then that many bytes of JSON:
    ``{name: {"dtype", "shape", "data_offsets"}, "__metadata__": {...}}``.
    """
    where = f"{card_path}: its weights {name}"
    if len(payload) < 8:
        raise ValueError(f"{where} are not a safetensors file (too short)")
    size = int.from_bytes(payload[:8], "little")
    if size > min(_MAX_HEADER_BYTES, len(payload) - 8):
        raise ValueError(f"{where} are not a safetensors file (a header of {size} bytes)")
    try:
        header = json.loads(payload[8 : 8 + size].decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise ValueError(f"{where} are not a safetensors file (its header is no JSON)") from None
    if not isinstance(header, dict):
        raise ValueError(f"{where} are not a safetensors file (its header is no object)")
    shapes: dict[str, tuple[int, ...]] = {}
    for key, entry in header.items():
        if key == "__metadata__":
            continue
        shape = entry.get("shape") if isinstance(entry, dict) else None
        if not (isinstance(shape, list) and all(type(n) is int and n >= 0 for n in shape)):
            raise ValueError(f"{where}: the tensor {key!r} has no shape in the header")
        shapes[str(key)] = tuple(shape)
    return shapes


def _check_header(card: dict[str, Any], card_path: Path, payload: bytes) -> None:
    """Refuse weights whose tensors are not the ones the card's architecture makes."""
    name = card["weights"]
    found = _header_shapes(payload, card_path, name)
    expected = policy_shapes(card)
    if found == expected:
        return
    missing = sorted(set(expected) - set(found))
    extra = sorted(set(found) - set(expected))
    wrong = sorted(k for k in set(found) & set(expected) if found[k] != expected[k])
    if wrong:
        key = wrong[0]
        what = f"{key} is {list(found[key])}, the architecture makes {list(expected[key])}"
    elif missing:
        what = f"they lack {missing[0]}" + (f" and {len(missing) - 1} more" if missing[1:] else "")
    else:
        what = f"they hold {extra[0]}, which the architecture does not make"
    raise ValueError(
        f"{card_path}: its weights {name} do not fit its architecture ({what}); nothing was "
        "built or loaded"
    )


def _check_settings(card: dict[str, Any], card_path: Path) -> None:
    """Check the task fields of a card (section, arm, ranges); the errors name the field."""
    from tooldesign_env.geometry import SECTION_SHAPES

    section = card["section_shape"]
    if not isinstance(section, str):
        raise TypeError(
            f"{card_path}: 'section_shape' must be one of {SECTION_SHAPES}, got {section!r}"
        )
    if section not in SECTION_SHAPES:
        raise ValueError(
            f"{card_path}: 'section_shape' must be one of {SECTION_SHAPES}, got {section!r}"
        )
    if not isinstance(card["merge_fixed_links"], bool):
        raise TypeError(
            f"{card_path}: 'merge_fixed_links' must be true or false, "
            f"got {card['merge_fixed_links']!r}"
        )
    if "goal_range" in card:
        what = "two (x, y, z) corners in m"
        _check_pairs(card["goal_range"], card_path, "goal_range", what)
        if len(card["goal_range"][0]) != 3:
            raise TypeError(f"{card_path}: 'goal_range' must be {what}, got {card['goal_range']!r}")
    if "mass_range" in card:
        value = card["mass_range"]
        pair = [[v] for v in value] if isinstance(value, list) else value
        _check_pairs(pair, card_path, "mass_range", "[low, high] in kg", shown=value)
        if value[0] <= 0:
            raise ValueError(f"{card_path}: 'mass_range' must be > 0 kg, got {value!r}")


def _check_pairs(value: Any, card_path: Path, name: str, what: str, *, shown: Any = None) -> None:
    """``value`` must be [low, high], two equally long lists of finite numbers, low <= high.

    ``shown``: what the card holds, for the message, if ``value`` was reshaped from it.
    """
    shown = value if shown is None else shown
    if (
        not isinstance(value, list)
        or len(value) != 2
        or any(not isinstance(corner, list) for corner in value)
        or len(value[0]) != len(value[1])
        or any(isinstance(v, bool) or not isinstance(v, (int, float)) for c in value for v in c)
    ):
        raise TypeError(f"{card_path}: '{name}' must be {what}, got {shown!r}")
    low, high = value
    if not all(math.isfinite(v) for v in (*low, *high)) or any(
        lo > hi for lo, hi in zip(low, high, strict=True)
    ):
        raise ValueError(
            f"{card_path}: '{name}' must be {what}, finite with low <= high, got {shown!r}"
        )


def policy_env_kwargs(card: dict[str, Any]) -> dict[str, Any]:
    """The ``ToolDesignRL-v0`` arguments that rebuild a card's training task (tool, scene).

    Args:
        card: a card from :func:`read_policy_card` or :func:`load_policy`.

    Returns:
        ``{"tool": ToolSpec(section_shape=...), "scene": SceneSpec(merge_fixed_links=...)}``.
    """
    from tooldesign_env.geometry import ToolSpec
    from tooldesign_env.specs import SceneSpec

    settings = {**CARD_ADDED_FIELDS, **card}
    return {
        "tool": ToolSpec(section_shape=settings["section_shape"]),
        "scene": SceneSpec(merge_fixed_links=settings["merge_fixed_links"]),
    }


def load_policy(
    path: str | os.PathLike[str], *, allow_pickle: bool = False, sha256: str | None = None
) -> tuple[Any, dict[str, Any]]:
    """Load a saved policy card; returns the policy (with ``predict``) and the card.

    The card is :func:`read_policy_card`'s: checked, with :data:`CARD_ADDED_FIELDS` filled in.
    The files are read once: their SHA-256 is checked against ``sha256`` (the one a run
    recorded) and the weights' against the card's ``weights_sha256`` before anything is parsed;
    the network is rebuilt from the card's ``architecture`` and the weights are plain tensors.

    Args:
        path: The card.
        allow_pickle: Load a card of format 1, whose Stable-Baselines3 ``.zip`` is unpickled
            and can run any code: only for a file from a source you trust (it warns).
        sha256: :func:`policy_digest` the policy must have (a run's record), or None.

    Raises:
        FileNotFoundError: no such card (or the file it names is missing).
        ValueError / TypeError: not a policy card of a known format and method, or a field of
            the wrong value or type; the message names the card and the field. A digest other
            than ``sha256`` or ``weights_sha256``, weights that do not fit the architecture, or
            a ``.zip`` without ``allow_pickle`` (:class:`UnsafePolicyError`).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {path!r}")
    if not isinstance(allow_pickle, bool):
        raise TypeError(f"allow_pickle must be True or False, got {allow_pickle!r}")
    card_path = Path(path)
    digest, card, payload = _read_policy(card_path)
    if sha256 is not None and digest != sha256:
        raise ValueError(
            f"the policy {card_path} has changed since the run began (SHA-256 {digest}, the "
            f"run recorded {sha256}); design into a new run folder"
        )
    method = card["method"]
    if method == "contextual":
        try:
            return ContextualPolicy.from_dict(card["policy"]), card
        except (TypeError, ValueError) as error:
            raise type(error)(f"{card_path}: 'policy': {error}") from None
    assert payload is not None  # a PPO or SAC card names its file (_read_policy)
    from benchmarks.rl.agents import _torch_single_thread, import_sb3

    sb3 = import_sb3()
    _torch_single_thread()
    if "weights" in card:
        return _policy_from_weights(card, card_path, payload), card
    if not allow_pickle:
        raise UnsafePolicyError(
            f"{card_path} names the Stable-Baselines3 file {card['file']}, which is loaded by "
            "unpickling and so can run any code it holds: load it only if you trust where it "
            "came from, with --allow-pickle (API: allow_pickle=True), or convert it once with "
            "benchmarks.rl.policies.convert_policy"
        )
    warnings.warn(
        f"loading {card['file']} of {card_path} unpickles it, which runs any code it holds: "
        "do this only for a policy from a source you trust",
        UserWarning,
        stacklevel=2,
    )
    import io

    algorithm = getattr(sb3, method.upper())
    return algorithm.load(io.BytesIO(payload), device="cpu"), card


def _policy_from_weights(card: dict[str, Any], card_path: Path, payload: bytes) -> Any:
    """The Stable-Baselines3 policy network of a format-2 card, its weights loaded."""
    import torch
    from gymnasium.spaces import Box
    from safetensors import SafetensorError
    from stable_baselines3.common.policies import ActorCriticPolicy, BasePolicy
    from stable_baselines3.sac.policies import SACPolicy

    _import_safetensors()  # first: a missing package names its extra
    actual = hashlib.sha256(payload).hexdigest()
    if actual != card["weights_sha256"]:
        raise ValueError(
            f"{card_path}: its weights {card['weights']} have changed since they were saved "
            f"(SHA-256 {actual[:12]}..., the card records {card['weights_sha256'][:12]}...)"
        )
    # The header alone, before the network is built: a card cannot make it build what its
    # weights do not hold (and the card's parameter count was bounded when it was read).
    _check_header(card, card_path, payload)
    arch = card["architecture"]

    def box(name: str) -> Box:
        fields = arch[name]
        return Box(
            low=np.asarray(fields["low"], dtype=np.float32),
            high=np.asarray(fields["high"], dtype=np.float32),
            dtype=np.float32,
        )

    kwargs: dict[str, Any] = {
        "observation_space": box("observation_space"),
        "action_space": box("action_space"),
        "lr_schedule": lambda _: 0.0,
        "net_arch": arch["net_arch"],
        "activation_fn": getattr(torch.nn, arch["activation_fn"]),  # one of _ACTIVATIONS
        "log_std_init": float(arch.get("log_std_init", 0.0)),
        "share_features_extractor": bool(arch.get("share_features_extractor", True)),
    }
    if card["method"] == "sac":
        kwargs.update(
            n_critics=int(arch.get("n_critics", 2)), clip_mean=float(arch.get("clip_mean", 2.0))
        )
        policy: BasePolicy = SACPolicy(**kwargs)
    else:
        policy = ActorCriticPolicy(**kwargs)
    try:
        state = _import_safetensors().load(payload)
        policy.load_state_dict(state, strict=True)
    except (SafetensorError, RuntimeError, ValueError) as error:
        first = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise ValueError(
            f"{card_path}: its weights {card['weights']} do not fit its architecture ({first})"
        ) from None
    policy.set_training_mode(False)
    return policy


def convert_policy(
    path: str | os.PathLike[str], out: str | os.PathLike[str] | None = None, *, allow_pickle: bool
) -> Path:
    """Turn a card of format 1 (a Stable-Baselines3 ``.zip``) into one of format 2 (safetensors).

    The ``.zip`` is unpickled once, here, so ``allow_pickle=True`` must be given: convert only a
    policy from a source you trust. The new card keeps every field of the old one (its task and
    ranges) and names ``<name>.safetensors`` beside it; the ``.zip`` is left as it is.

    Args:
        path: The card of format 1.
        out: The new card (default: ``path`` itself, rewritten atomically).
        allow_pickle: Must be True: the acknowledgement that the ``.zip`` runs code.

    Returns:
        The new card's path.

    Raises:
        UnsafePolicyError: ``allow_pickle`` is not True.
        ValueError: not a PPO or SAC card of format 1.
    """
    if allow_pickle is not True:
        raise UnsafePolicyError(
            "converting a Stable-Baselines3 .zip unpickles it, which runs any code it holds: "
            "pass allow_pickle=True for a policy from a source you trust"
        )
    card_path = Path(path)
    raw = json.loads(_read_card_bytes(card_path))
    if raw.get("format") != 1 or raw.get("method") not in ("ppo", "sac"):
        raise ValueError(f"{card_path} is not a PPO or SAC card of format 1")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the acknowledged pickle warning
        model, _ = load_policy(card_path, allow_pickle=True)
    target = card_path if out is None else Path(out)
    if target.suffix != ".json":
        raise ValueError(f"out must end in .json (the policy card), got {str(target)!r}")
    card = {k: v for k, v in raw.items() if k != "file"}
    card["format"] = POLICY_FORMAT
    card.update(_weights_fields(model.policy, raw["method"], target))
    return atomic_write_text(target, json_text(card))


def _check_observation(card: dict[str, Any], card_path: Any, space: Any) -> None:
    """Refuse a policy whose recorded observation box is not the env's (another task)."""
    fields = card["architecture"]["observation_space"]
    low = np.asarray(space.low, dtype=np.float32).ravel().tolist()
    high = np.asarray(space.high, dtype=np.float32).ravel().tolist()
    recorded = (
        np.asarray(fields["low"], dtype=np.float32).tolist(),
        np.asarray(fields["high"], dtype=np.float32).tolist(),
    )
    if (low, high) != recorded:
        raise ValueError(
            f"{card_path} was trained on observations in {recorded[0]} to {recorded[1]}, but "
            f"ToolDesignRL-v0 observes {low} to {high}: it is a policy of another task"
        )


def _warn_outside_training(card: dict[str, Any], card_path: Any, goal: Any, mass: float) -> None:
    """Warn when the task lies outside the ranges the card records (none: no warning)."""
    if "goal_range" in card:
        low, high = (np.asarray(corner, dtype=float) for corner in card["goal_range"])
        g = np.asarray(goal, dtype=float)
        if np.any(g < low) or np.any(g > high):
            warnings.warn(
                f"the goal {g.tolist()} is outside the goals {card_path} was trained on "
                f"({low.tolist()} to {high.tolist()} m): the policy extrapolates",
                UserWarning,
                stacklevel=3,
            )
    if "mass_range" in card:
        lo, hi = (float(v) for v in card["mass_range"])
        if not lo <= mass <= hi:
            warnings.warn(
                f"the box mass {mass:g} kg is outside the masses {card_path} was trained on "
                f"({lo:g} to {hi:g} kg): the policy extrapolates",
                UserWarning,
                stacklevel=3,
            )


def design_for_goal(
    policy_path: str | os.PathLike[str],
    goal: Sequence[float],
    *,
    box_mass: float = DEFAULT_BOX_MASS,
    simulate: bool = True,
    allow_pickle: bool = False,
    sha256: str | None = None,
) -> DesignResult:
    """Design a tool for ``goal`` with a saved policy (zero-shot), and score it.

    Args:
        policy_path: a policy card written by :func:`save_policy`.
        goal: (x, y, z) in m, inside the workspace (x, y in [-2.5, 2.5], z in [0, 1]); the
            policies were trained on x in [-0.5, 0.5], y in [0.5, 1.5], z = 0.1.
        box_mass: the box mass in kg.
        simulate: simulate the tool to report F (one episode, about 0.2 s); False returns the
            design only.
        allow_pickle: load a card of format 1 (a Stable-Baselines3 ``.zip``, which runs code
            when loaded); see :func:`load_policy`.
        sha256: the :func:`policy_digest` the policy must have (checked before it is loaded).

    The tool is simulated with the section and arm the policy was trained with (the card's
    ``section_shape`` and ``merge_fixed_links``; the committed cards: square, 13 links). A goal
    closer than :data:`~tooldesign_env.rl.MIN_GOAL_DISTANCE` to the box's start is designed and
    scored by F alone: its ``normalized_reward`` is NaN (the reward has no scale there). A goal
    or mass outside the card's ``goal_range`` / ``mass_range`` warns (``UserWarning``); a card
    without them (those written before the fields) never warns.

    Returns:
        The design, and its F when simulated.

    Raises:
        TypeError / ValueError: a bad goal or box mass (from the env), a bad card.
        FileNotFoundError: no such card.
    """
    if not isinstance(simulate, bool):
        raise TypeError(f"simulate must be True or False, got {simulate!r}")
    policy, card = load_policy(policy_path, allow_pickle=allow_pickle, sha256=sha256)
    # reward="free-energy" takes every goal: one within MIN_GOAL_DISTANCE of the box's start,
    # where the normalized reward has no scale, is designed and scored by F alone. The record's
    # normalized reward is info's either way (NaN that near).
    env = make_env(**policy_env_kwargs(card), reward="free-energy")
    logged = EpisodeLog(env)
    try:
        if "architecture" in card:
            _check_observation(card, policy_path, env.observation_space)
        obs, info = logged.reset(options={"goal": goal, "box_mass": box_mass})
        _warn_outside_training(card, policy_path, info["goal"], float(info["box_mass"]))
        action, _ = policy.predict(obs, deterministic=True)
        action = np.clip(np.asarray(action, dtype=np.float32).ravel(), -1.0, 1.0)
        coefficients = env.to_coefficients(action)
        nan = float("nan")
        result = DesignResult(
            goal=tuple(float(v) for v in info["goal"]),  # type: ignore[arg-type]
            box_mass=float(info["box_mass"]),
            action=tuple(float(a) for a in action),
            coefficients=tuple(float(c) for c in coefficients),
            free_energy=nan,
            normalized_reward=nan,
            final_distance=nan,
            valid=None,
        )
        if simulate:
            logged.step(action)
            record = logged.records[-1]
            result = dataclasses.replace(
                result,
                free_energy=record.free_energy,
                normalized_reward=record.reward,
                final_distance=record.final_distance,
                valid=record.valid,
            )
    finally:
        logged.close()
    return result
