"""A policy file is data: loaded without pickle, checked before it is parsed (issue 33).

PPO's and SAC's weights are a safetensors state dict whose SHA-256 the card records; the network is
rebuilt from the card's JSON. A Stable-Baselines3 ``.zip`` (which unpickles, so runs code) loads
only behind ``allow_pickle`` / ``--allow-pickle``, with a warning; a card's file outside its folder
(a path, ``..``, a link) is refused.
"""

from __future__ import annotations

import base64
import contextlib
import json
import pickle
import shutil
import warnings
import zipfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmarks.cli import main
from benchmarks.rl.policies import (
    UnsafePolicyError,
    convert_policy,
    design_for_goal,
    load_policy,
    policy_digest,
)

ROOT = Path(__file__).resolve().parents[1]
POLICIES = ROOT / "docs" / "results" / "square" / "rl" / "policies"
GOAL = (0.2, 1.0, 0.1)


class _Payload:
    """Unpickled, it creates a file: what a crafted policy could do."""

    def __init__(self, marker: Path) -> None:
        self.marker = str(marker)

    def __reduce__(self):  # type: ignore[no-untyped-def]
        return (open, (self.marker, "w"))


def _crafted_zip(folder: Path, marker: Path) -> Path:
    """A format-1 PPO card whose .zip holds a pickled entry that runs code when loaded."""
    folder.mkdir(parents=True, exist_ok=True)
    serialized = base64.b64encode(pickle.dumps(_Payload(marker))).decode()
    data = {"policy_class": {":type:": "<class 'x'>", ":serialized:": serialized}}
    with zipfile.ZipFile(folder / "evil.zip", "w") as archive:
        archive.writestr("data", json.dumps(data))
    card = folder / "evil.json"
    card.write_text(json.dumps({"format": 1, "method": "ppo", "file": "evil.zip"}))
    return card


def _copy_card(tmp_path: Path, name: str = "ppo") -> Path:
    folder = tmp_path / "policies"
    folder.mkdir(exist_ok=True)
    shutil.copy(POLICIES / f"{name}.json", folder)
    shutil.copy(POLICIES / f"{name}.safetensors", folder)
    return folder / f"{name}.json"


def _edit(card: Path, **fields: object) -> None:
    data = json.loads(card.read_text())
    data.update(fields)
    card.write_text(json.dumps(data))


def _edit_architecture(card: Path, **fields: object) -> None:
    data = json.loads(card.read_text())
    data["architecture"] = {**data["architecture"], **fields}
    card.write_text(json.dumps(data))


@pytest.mark.slow
def test_a_crafted_zip_runs_nothing_without_the_flag(tmp_path: Path) -> None:
    marker = tmp_path / "ran"
    card = _crafted_zip(tmp_path / "p", marker)
    with pytest.raises(UnsafePolicyError, match="unpickling and so can run any code"):
        load_policy(card)
    with pytest.raises(UnsafePolicyError, match="--allow-pickle"):
        design_for_goal(card, GOAL, simulate=False)
    assert not marker.exists()
    # Behind the flag it is unpickled, as Stable-Baselines3 does, and the command warns first.
    with pytest.warns(UserWarning, match="runs any code it holds"):
        with contextlib.suppress(Exception):
            load_policy(card, allow_pickle=True)
    assert marker.exists()  # what the flag guards against, shown


def test_the_design_command_refuses_a_zip_in_one_line(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    marker = tmp_path / "ran"
    card = _crafted_zip(tmp_path / "p", marker)
    argv = ["design", "--policy", str(card), "--goal", *map(str, GOAL)]
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--out", str(tmp_path / "run")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "can run any code" in err and "--allow-pickle" in err and err.count("\n") == 1
    assert not marker.exists()
    with pytest.raises(SystemExit) as exit_info:
        main(["design", "--allow-pickle", "--out", str(tmp_path / "run2")])
    assert exit_info.value.code == 2
    assert "give it with --policy" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("fields", "words"),
    [
        ({"weights": "../elsewhere/ppo.safetensors"}, "is a path"),
        ({"weights": "/etc/ppo.safetensors"}, "is a path"),
        ({"format": 1, "file": "../elsewhere/ppo.zip", "weights": None}, "is a path"),
    ],
)
def test_a_file_outside_the_cards_folder_is_refused(
    tmp_path: Path, fields: dict[str, object], words: str
) -> None:
    card = _copy_card(tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    shutil.copy(POLICIES / "ppo.safetensors", elsewhere)
    data = json.loads(card.read_text())
    data.update({k: v for k, v in fields.items() if v is not None})
    if fields.get("weights", "") is None:
        data.pop("weights")
    card.write_text(json.dumps(data))
    with pytest.raises(UnsafePolicyError, match=words):
        policy_digest(card)
    with pytest.raises(UnsafePolicyError, match=words):
        load_policy(card, allow_pickle=True)


def test_a_linked_weights_file_is_refused(tmp_path: Path) -> None:
    card = _copy_card(tmp_path)
    weights = card.with_suffix(".safetensors")
    target = tmp_path / "elsewhere.safetensors"
    weights.rename(target)
    weights.symlink_to(target)
    with pytest.raises(UnsafePolicyError, match="symbolic link"):
        load_policy(card)


def test_the_recorded_sha256_is_checked_before_anything_is_parsed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import safetensors.torch

    def parse(*args: object) -> None:
        raise AssertionError("the weights were parsed before their digest was checked")

    card = _copy_card(tmp_path)
    digest = policy_digest(card)
    weights = card.with_suffix(".safetensors")
    raw = bytearray(weights.read_bytes())
    raw[-1] ^= 1
    weights.write_bytes(bytes(raw))
    monkeypatch.setattr(safetensors.torch, "load", parse)
    with pytest.raises(ValueError, match="has changed since the run began"):
        load_policy(card, sha256=digest)
    with pytest.raises(ValueError, match="weights ppo.safetensors have changed since they were"):
        load_policy(card)


@pytest.mark.parametrize(
    ("architecture", "words"),
    [
        ({"activation_fn": "os.system"}, "'architecture.activation_fn' must be one of"),
        ({"net_arch": [32, 32]}, "do not fit its architecture"),
        ({"net_arch": "64"}, "'architecture.net_arch' must be a list"),
        ({"observation_space": {"shape": [4]}}, "architecture.observation_space"),
    ],
)
def test_a_bad_architecture_is_refused_naming_the_field(
    tmp_path: Path, architecture: dict[str, object], words: str
) -> None:
    card = _copy_card(tmp_path)
    data = json.loads(card.read_text())
    data["architecture"] = {**data["architecture"], **architecture}
    card.write_text(json.dumps(data))
    with pytest.raises((ValueError, TypeError), match=words):
        load_policy(card)


def test_bad_flags_of_the_loader_are_refused(tmp_path: Path) -> None:
    card = _copy_card(tmp_path)
    with pytest.raises(TypeError, match="allow_pickle must be True or False"):
        load_policy(card, allow_pickle="yes")  # type: ignore[arg-type]
    with pytest.raises(UnsafePolicyError, match="allow_pickle=True"):
        convert_policy(card, allow_pickle=False)
    with pytest.raises(ValueError, match="not a PPO or SAC card of format 1"):
        convert_policy(card, allow_pickle=True)


@pytest.mark.slow
def test_a_converted_zip_designs_what_the_zip_did(tmp_path: Path) -> None:
    """convert_policy: the same weights, bit for bit, without pickle from then on."""
    from benchmarks.rl.agents import import_sb3, make_env

    policy, _ = load_policy(POLICIES / "ppo.json")
    env = make_env()
    model = import_sb3().PPO(
        "MlpPolicy",
        env,
        policy_kwargs={"net_arch": [64, 64], "log_std_init": -2.0},
        device="cpu",
    )
    env.close()
    model.policy.load_state_dict(policy.state_dict())
    folder = tmp_path / "old"
    folder.mkdir()
    model.save(folder / "ppo.zip")  # a format-1 card, as the committed ones were
    old = json.loads((POLICIES / "ppo.json").read_text())
    for key in ("weights", "weights_sha256", "architecture"):
        old.pop(key)
    (folder / "ppo.json").write_text(json.dumps({**old, "format": 1, "file": "ppo.zip"}))
    with pytest.warns(UserWarning, match="runs any code"):
        before = design_for_goal(folder / "ppo.json", GOAL, simulate=False, allow_pickle=True)
    new = convert_policy(folder / "ppo.json", folder / "new.json", allow_pickle=True)
    assert json.loads(new.read_text())["weights"] == "new.safetensors"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no pickle, no warning
        after = design_for_goal(new, GOAL, simulate=False)
    assert after.coefficients == before.coefficients
    assert (
        after.coefficients
        == design_for_goal(POLICIES / "ppo.json", GOAL, simulate=False).coefficients
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "coefficients", "free_energy"),
    [("ppo", [1.136, -0.164, -0.148], 4564), ("sac", [0.214, 0.165, -0.014], 5998)],
)
def test_the_committed_cards_design_without_the_flag_as_documented(
    tmp_path: Path, name: str, coefficients: list[float], free_energy: int
) -> None:
    # docs/rl.md: "PPO C = (1.136, -0.164, -0.148), F 4564; SAC C = (0.214, 0.165, -0.014), F 5998"
    card = POLICIES / f"{name}.json"
    assert json.loads(card.read_text())["format"] == 2
    assert not card.with_suffix(".zip").exists()
    result = design_for_goal(card, GOAL)
    assert [round(c, 3) for c in result.coefficients] == coefficients
    assert round(result.free_energy) == free_energy
    out = tmp_path / "run"
    argv = ["design", "--policy", str(card), "--goal", *map(str, GOAL), "--out", str(out)]
    assert main(argv) == 0
    design = json.loads((out / "design.json").read_text())
    assert design["free_energy"] == result.free_energy


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(name=st.text(alphabet="./\\~ab-_:\x00", min_size=1, max_size=16))
def test_no_weights_name_reads_outside_the_cards_folder(tmp_path: Path, name: str) -> None:
    folder = tmp_path / "policies"
    if not folder.exists():
        _copy_card(tmp_path, "ppo")
        for outside in ("x", "a", "b"):  # what a name going up could reach
            shutil.copy(POLICIES / "ppo.safetensors", tmp_path / f"{outside}.safetensors")
    card = folder / "ppo.json"
    _edit(card, weights=name + ".safetensors")
    try:
        policy_digest(card)
    except (ValueError, TypeError, OSError):
        return
    assert (folder / (name + ".safetensors")).resolve().parent == folder.resolve()


# --- a card cannot make the loader build what its weights do not hold (L4) -----------------------
def test_a_format_1_card_with_weights_is_refused(tmp_path: Path) -> None:
    """Its weights fields would be loaded unchecked (activation "Identity", no layers)."""
    card = _copy_card(tmp_path)
    data = json.loads(card.read_text())
    data["format"] = 1
    data["architecture"] = {**data["architecture"], "activation_fn": "Identity", "net_arch": []}
    card.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="a card of format 1 names .*'weights' belongs to"):
        load_policy(card)
    with pytest.raises(ValueError, match="'weights' belongs to a card of format 2"):
        load_policy(card, allow_pickle=True)


def test_a_huge_architecture_is_refused_before_anything_is_built(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import benchmarks.rl.policies as policies

    built: list[object] = []
    monkeypatch.setattr(
        "stable_baselines3.common.policies.ActorCriticPolicy.__init__",
        lambda *a, **k: built.append(a) or (_ for _ in ()).throw(AssertionError("built")),
    )
    card = _copy_card(tmp_path)
    _edit_architecture(card, net_arch=[65536] * 40)  # a 1 kB card asking for 170 G parameters
    with pytest.raises(ValueError, match="parameters, more than the 16,000,000"):
        policies.read_policy_card(card)
    with pytest.raises(ValueError, match="parameters, more than"):
        load_policy(card)
    assert not built


@pytest.mark.parametrize(
    ("net_arch", "words"),
    [
        ([64], "do not fit its architecture .*hold mlp_extractor.policy_net.2"),
        ([64, 64, 64], "do not fit its architecture .*lack mlp_extractor.policy_net.4"),
        ([32, 64], r"policy_net.0.(weight|bias) is \[64.*\], the architecture makes \[32"),
    ],
)
def test_weights_of_another_architecture_are_refused_from_the_header(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, net_arch: list[int], words: str
) -> None:
    built: list[object] = []
    monkeypatch.setattr(
        "stable_baselines3.common.policies.ActorCriticPolicy.__init__",
        lambda *a, **k: built.append(a) or (_ for _ in ()).throw(AssertionError("built")),
    )
    card = _copy_card(tmp_path)
    _edit_architecture(card, net_arch=net_arch)
    with pytest.raises(ValueError, match=words):
        load_policy(card)
    assert not built  # refused from the header, before the network was built


@pytest.mark.parametrize(
    ("method", "net_arch", "extra"),
    [
        ("ppo", [8, 9], {}),
        ("ppo", {"pi": [7, 8], "vf": [9]}, {}),
        ("ppo", {"vf": [5]}, {}),
        ("sac", [8, 9], {"n_critics": 3}),
        ("sac", {"pi": [7], "qf": [9, 4]}, {"share_features_extractor": False}),
    ],
)
def test_the_shapes_a_card_describes_are_what_stable_baselines3_builds(
    method: str, net_arch: object, extra: dict[str, object]
) -> None:
    import numpy as np
    import torch
    from gymnasium.spaces import Box
    from stable_baselines3.common.policies import ActorCriticPolicy
    from stable_baselines3.sac.policies import SACPolicy

    from benchmarks.rl.policies import policy_shapes

    box = {"shape": [5], "low": [-1.0] * 5, "high": [1.0] * 5}
    act = {"shape": [3], "low": [-1.0] * 3, "high": [1.0] * 3}
    card = {
        "method": method,
        "architecture": {
            "observation_space": box,
            "action_space": act,
            "net_arch": net_arch,
            **extra,
        },
    }
    kwargs: dict[str, object] = {
        "observation_space": Box(-1, 1, (5,), np.float32),
        "action_space": Box(-1, 1, (3,), np.float32),
        "lr_schedule": lambda _: 0.0,
        "net_arch": net_arch,
        "activation_fn": torch.nn.Tanh,
        **extra,
    }
    policy = SACPolicy(**kwargs) if method == "sac" else ActorCriticPolicy(**kwargs)
    built = {k: tuple(v.shape) for k, v in policy.state_dict().items()}
    assert policy_shapes(card) == built
