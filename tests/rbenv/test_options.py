"""The env options are declared once (rbenv.envs.options.EnvOptions); the constructors, the env
docstrings and docs/api.md agree with the declaration, and what it says of defaults is true."""

from __future__ import annotations

import dataclasses
import inspect
import re
from pathlib import Path

import gymnasium as gym
import pytest

import rbenv
from rbenv.envs import options
from rbenv.envs.env import AttitudeEnv
from rbenv.envs.goal import GoalReorientEnv
from rbenv.envs.vector_env import AttitudeVectorEnv
from rbenv.satellite.plant import make_plant
from rbenv.tasks import build

ROOT = Path(__file__).resolve().parents[2]
SCENES = rbenv.list_scenes()


def _keywords(function, skip=()) -> dict:
    return {name: p.default for name, p in inspect.signature(function).parameters.items()
            if p.kind is p.KEYWORD_ONLY or (p.kind is p.POSITIONAL_OR_KEYWORD and
                                             name not in ("self", "spec", "num_envs"))
            if name not in skip}


def test_tasks_build_takes_exactly_the_env_options_with_their_defaults():
    assert _keywords(build) == options.DEFAULTS


def _shell_class(shell: str):
    if shell.startswith("torch"):
        pytest.importorskip("torch", reason="torch is not installed (train extra)")
        from rbenv.envs.torch_env import TorchEnv, TorchVectorEnv

        return TorchVectorEnv if shell == "torch" else TorchEnv
    return {"single": AttitudeEnv, "numpy": AttitudeVectorEnv, "goal": GoalReorientEnv}[shell]


@pytest.mark.parametrize("shell", sorted(options.OPTIONS_OF))
def test_each_shell_takes_the_options_declared_for_it_and_refuses_the_rest(shell):
    """One constructor per shell, ``(num_envs, scene, **options)`` (the goal env: its
    options), each checked by ``options.take``: the names it takes are
    ``options.OPTIONS_OF[shell]``, declared once; each is accepted at its declared default, and
    a name of another shell, or ``backend`` (the registry's entry points take it), is refused
    by name."""
    cls = _shell_class(shell)
    task = rbenv.envs.registry.get(rbenv.ENV_ID)
    declared = options.take(cls.__name__, shell, {})
    given = {**declared, "integrator": "rk4"}
    if shell != "goal":
        given["task"] = task
    env = cls(**{k: v for k, v in given.items() if k != "num_envs"}, num_envs=2) \
        if "num_envs" in given else cls(**given)
    inner = getattr(env, "env", env)  # the goal env's and TorchEnv's inner env
    assert inner.plant.scene.name == "cubesat-12u"
    assert inner.task_spec is (task if shell != "goal" else rbenv.envs.registry.get(
        "rbenv/SatelliteReorient-v1"))
    others = set().union(*options.OPTIONS_OF.values(), ["backend"]) - \
        set(options.OPTIONS_OF[shell])
    for name in sorted(others):
        with pytest.raises(TypeError, match=f"unexpected keyword argument {name!r}"):
            cls(**{name: None} if shell == "goal" else {name: None, "task": task})


def test_make_plant_takes_the_plant_options_with_the_declared_defaults():
    plant_options = _keywords(make_plant, skip=("scene",))  # the plant needs its scene
    assert plant_options == {k: options.DEFAULTS[k] for k in plant_options}


def test_every_option_is_documented_and_an_unknown_one_is_refused_naming_the_valid_ones():
    docs = options.field_docs(options.EnvOptions)
    assert set(docs) == set(options.ENV_OPTIONS) and all(docs.values())
    with pytest.raises(TypeError, match=r"'integrater'.*valid options are.*integrator"):
        gym.make(rbenv.ENV_ID, integrater="rk4")


def test_the_env_docstring_holds_the_generated_arguments_table():
    assert options.options_table() in gym.make(rbenv.ENV_ID).unwrapped.__doc__
    table = options.options_table()
    for name in (*options.ENV_OPTIONS, "render_mode"):
        assert f"``{name}``" in table


def test_docs_api_md_holds_the_generated_options_table():
    assert options.options_markdown() in (ROOT / "docs" / "api.md").read_text()


def _listed(doc: str, key: str) -> set[str]:
    """Scene names after ``key:`` up to the next ';' or ')' in a docstring."""
    found = re.search(rf"{key}: ([^;)]*)", doc)
    return {s.strip() for s in found.group(1).split(",")} if found else set()


def test_the_integrator_default_named_per_scene_is_the_scenes():
    doc = options.field_docs(options.EnvOptions)["integrator"]
    for scene in SCENES:
        integrator = rbenv.load_scene(scene).physics.integrator
        assert scene in _listed(doc, integrator), (scene, integrator)
        env = gym.make(rbenv.ENV_ID, scene=scene).unwrapped
        assert env.plant.scene.physics.integrator == integrator


def test_the_randomization_default_named_per_scene_is_the_scenes():
    doc = options.field_docs(options.EnvOptions)["randomize"]
    on = {s for s in SCENES if any(vars(rbenv.load_scene(s).randomization).values())}
    assert on == _listed(doc, "on")


def test_the_default_scene_named_per_task_is_the_tasks():
    doc = options.field_docs(options.EnvOptions)["scene"]
    for env_id in rbenv.ENV_IDS:
        scene = gym.make(env_id).unwrapped.plant.scene.name
        assert f"``{scene}``" in doc, (env_id, scene)


@pytest.mark.parametrize("env_id", sorted(rbenv.ENV_IDS))
def test_every_task_option_is_documented_and_every_documented_one_is_real(env_id):
    env = gym.make(env_id).unwrapped
    doc = env.__doc__
    keys = set(getattr(type(env.task), "OPTIONS", {}))
    for key in keys:
        assert f"``{key}``" in doc, key
    named = re.search(r"``task_options`` overrides the scene's ``\[tasks\.\w+\]``\s+table:"
                      r"(.*?)\n\n", doc, re.S)
    if named:
        assert set(re.findall(r"``(\w+)`` \(", named.group(1))) <= keys


@pytest.mark.parametrize("backend", ["numpy", "torch"])
def test_an_unknown_option_reads_as_pythons_own_error_and_names_the_valid_ones(backend):
    """Clients match Python's wording to drop an option the env does not take (TorchRL's
    GymEnv drops frameskip when the message says "unexpected keyword argument 'frameskip'")."""
    if backend == "torch":
        pytest.importorskip("torch", reason="torch is not installed (train extra)")
    with pytest.raises(TypeError) as err:
        gym.make("rbenv/SatelliteReorient-v1", backend=backend, frameskip=4)
    assert "unexpected keyword argument 'frameskip'" in str(err.value)
    assert "scene" in str(err.value) and "reward_weights" in str(err.value)
    with pytest.raises(TypeError, match=r"argument 'frameskip' \(and 'zzz'\); the valid"):
        gym.make_vec("rbenv/SatelliteReorient-v1", num_envs=2, backend=backend, frameskip=4,
                     zzz=1)


def test_the_backend_options_are_the_torch_envs_defaults():
    """What BackendOptions declares is what a torch env made without options runs with."""
    declared = {f.name: f.default for f in dataclasses.fields(options.BackendOptions)}
    assert declared["backend"] == "numpy"
    assert type(gym.make_vec(rbenv.ENV_ID, num_envs=2).unwrapped).__name__ == \
        "SatelliteReorientV2VectorEnv"
    pytest.importorskip("torch", reason="torch is not installed (train extra)")
    env = gym.make_vec(rbenv.ENV_ID, num_envs=2, backend="torch", integrator="rk4").unwrapped
    assert (str(env.device), str(env.dtype).removeprefix("torch."), env.check_every) == \
        (declared["device"], declared["dtype"], declared["check_every"])
    assert env._step_fn == env._physics  # compile=False: eager
    table = options.options_markdown()
    assert all(f"| `{name}` |" in table for name in options.BACKEND_OPTIONS)


def _vector(backend: str, **kwargs):
    if backend == "torch":
        pytest.importorskip("torch", reason="torch is not installed (train extra)")
        kwargs.update(backend="torch", integrator="rk4")
    return gym.make_vec(rbenv.ENV_ID, num_envs=2, max_episode_steps=1, **kwargs)


@pytest.mark.parametrize("backend", ["numpy", "torch"])
def test_the_autoreset_default_is_declared_once_and_every_vector_env_follows_it(monkeypatch,
                                                                                backend):
    """rbenv.envs.options.AUTORESET_DEFAULT is the one place, one mode for every backend:
    change it there, and a vector env made without ``autoreset_mode`` takes the new mode and
    acts on it (the modes themselves are written once, in rbenv.envs.vector)."""
    from gymnasium.vector import AutoresetMode

    assert options.AUTORESET_DEFAULT is AutoresetMode.NEXT_STEP
    envs = _vector(backend)
    assert envs.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    envs.reset(seed=0)
    zeros = envs.action_space.sample() * 0
    *_, truncated, info = envs.step(zeros)
    assert truncated.all() and "final_obs" not in info
    _, reward, _, truncated, _ = envs.step(zeros)  # NEXT_STEP: the restart step, flags False
    assert not truncated.any() and not reward.any()

    monkeypatch.setattr(options, "AUTORESET_DEFAULT", AutoresetMode.SAME_STEP)
    envs = _vector(backend)
    assert envs.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    envs.reset(seed=0)
    *_, truncated, info = envs.step(zeros)
    assert truncated.all() and info["_final_obs"].all()  # SAME_STEP's final observations

    monkeypatch.setattr(options, "AUTORESET_DEFAULT", AutoresetMode.DISABLED)
    envs = _vector(backend)
    assert envs.metadata["autoreset_mode"] is AutoresetMode.DISABLED
    envs.reset(seed=0)
    envs.step(zeros)
    with pytest.raises(gym.error.ResetNeeded, match=r"sub-envs \[0, 1\] have ended"):
        envs.step(zeros)  # nothing reset by itself
