"""PPO's settings have one source, rbenv.agents.settings.tuned (the training entries point at
it):
`rbenv train` (SB3), `rbenv train --engine rllib` and the RL Zoo file read it; none keeps a
copy (issue 21 item 2)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from rbenv.agents import settings
from rbenv.agents.settings import tuned

ROOT = Path(__file__).resolve().parents[3]
# Settings only PPO has, under SB3's and RLlib's names; the readers must not hold the shared
# ones either.
PPO_ONLY = {"n_epochs", "num_epochs", "gae_lambda", "lambda_", "clip_range", "clip_param",
            "minibatch_size", "train_batch_size_per_learner", "fcnet_hiddens"}
SHARED = {"learning_rate", "lr", "ent_coef", "entropy_coeff", "log_std_init"}
READERS = {"agents/training/config.py": PPO_ONLY | SHARED,
           "agents/training/sb3.py": PPO_ONLY | SHARED,
           "agents/training/rllib.py": PPO_ONLY | SHARED}


def _literal_keys(tree: ast.AST, keys: set) -> set:
    """PPO keys given a number (or a list of numbers) in a dict literal or a keyword."""
    found = set()
    for node in ast.walk(tree):
        pairs = []
        if isinstance(node, ast.Dict):
            pairs = [(k.value, v) for k, v in zip(node.keys, node.values, strict=True)
                     if isinstance(k, ast.Constant)]
        elif isinstance(node, ast.Call):
            pairs = [(kw.arg, kw.value) for kw in node.keywords]
        for key, value in pairs:
            if key in keys and _is_number(value):
                found.add(key)
    return found


def _is_number(node) -> bool:
    if isinstance(node, ast.UnaryOp):
        node = node.operand
    if isinstance(node, ast.List):
        return bool(node.elts) and all(_is_number(e) for e in node.elts)
    return isinstance(node, ast.Constant) and isinstance(node.value, int | float) \
        and not isinstance(node.value, bool)


@pytest.mark.parametrize("path", list(READERS))
def test_readers_hold_no_ppo_numbers_and_import_the_source(path):
    tree = ast.parse((ROOT / path).read_text())
    assert _literal_keys(tree, READERS[path]) == set(), f"{path} restates PPO settings"
    if path.endswith("sb3.py"):  # it takes its settings from the config (config.py)
        return
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert imported & {"rbenv.agents", "rbenv.agents.settings", "rbenv.agents.zoo.ppo"}


def test_a_change_in_the_source_reaches_every_reader(monkeypatch):
    """Change tuned.PPO in place: SB3's and RLlib's defaults follow (they read, not copy)."""
    from rbenv.agents.training.config import shipped_settings
    from rbenv.agents.training.rllib import RLlibConfig

    monkeypatch.setitem(tuned.PPO, "learning_rate", 1.234e-4)
    monkeypatch.setitem(tuned.PPO, "n_epochs", 7)
    monkeypatch.setitem(tuned.PPO, "gae_lambda", 0.9)
    # Reorient-v1 has its own PPO values (its id_settings); the rest still follows the source.
    v1 = settings.get("rbenv/SatelliteReorient-v1")
    assert v1.hyperparams["ppo"] is tuned.PPO
    assert shipped_settings("ppo", v1.env_id)["gae_lambda"] == 0.9
    assert shipped_settings("ppo", v1.env_id)["learning_rate"] == \
        v1.id_settings["ppo"]["learning_rate"] != 1.234e-4
    own = v1.id_settings["ppo"]
    cfg = RLlibConfig(env_id=v1.env_id).resolve()
    assert (cfg.hyperparams["lr"], cfg.hyperparams["train_batch_size_per_learner"]) == \
        (own["learning_rate"], own["n_envs"] * own["n_steps"])
    for env_id in ("rbenv/SatelliteReorient-v0", "rbenv/SatelliteTrack-v1"):
        assert settings.get(env_id).hyperparams["ppo"] is tuned.PPO
        assert shipped_settings("ppo", env_id)["learning_rate"] == 1.234e-4
        cfg = RLlibConfig(env_id=env_id).resolve()
        assert (cfg.hyperparams["lr"], cfg.hyperparams["num_epochs"]) == (1.234e-4, 7)
        assert cfg.hyperparams["train_batch_size_per_learner"] == \
            tuned.PPO["n_envs"] * tuned.PPO["n_steps"]
        assert cfg.model["fcnet_hiddens"] == tuned.PPO["policy_kwargs"]["net_arch"]
        assert cfg.log_std_init == tuned.PPO["policy_kwargs"]["log_std_init"]
    assert settings.zoo_hyperparams("ppo")["rbenv/SatelliteReorient-v0"]["n_epochs"] == 7


def test_the_main_job_trains_reorient_v2_to_its_budget_and_v1_keeps_its_settings():
    """``rbenv train`` with no arguments: Reorient-v2 (rbenv.ENV_ID), v1's PPO updates to
    2 M steps, no early stop; Reorient-v1's own entry is unchanged."""
    from rbenv.agents.settings import shipped
    from rbenv.agents.training.config import TrainConfig

    import rbenv

    assert rbenv.ENV_ID == "rbenv/SatelliteReorient-v2"
    cfg = TrainConfig().resolve()
    assert (cfg.env_id, cfg.algo, cfg.timesteps) == (rbenv.ENV_ID, "ppo", 2_000_000)
    assert cfg.stop_success == 0.0 and "reward_weights" not in cfg.env_kwargs
    assert cfg.hyperparams["policy_kwargs"] == shipped.REORIENT_V1_PPO["policy_kwargs"]
    assert {k: cfg.hyperparams[k] for k in ("n_steps", "batch_size", "n_epochs", "gamma")} \
        == {k: shipped.REORIENT_V1_PPO[k] for k in ("n_steps", "batch_size", "n_epochs",
                                                      "gamma")}
    v1 = TrainConfig(env_id="rbenv/SatelliteReorient-v1").resolve()
    assert (v1.timesteps, v1.stop_success) == (600_000, 1.0)


def test_reorient_v1_ppo_settings_reach_train_and_the_zoo():
    """Reorient-v1's own PPO values (its fast path, docs/performance.md) are what `rbenv train`
    and the RL Zoo file use on that id; the keys it does not set are the shared dict's."""
    import importlib

    from rbenv.agents.training.config import TrainConfig, shipped_settings

    env_id = "rbenv/SatelliteReorient-v1"
    own = settings.get(env_id).id_settings["ppo"]
    zoo = importlib.import_module("rbenv.agents.zoo.ppo").hyperparams[env_id]
    assert shipped_settings("ppo", env_id) == {**tuned.PPO, **own}
    # The zoo gets the same dict, with the activation's name made the class SB3 builds.
    from rbenv.agents.policies.activations import Tanh

    assert own["policy_kwargs"]["activation_fn"] == "tanh"
    assert zoo == {**tuned.PPO, **own,
                   "policy_kwargs": {**own["policy_kwargs"], "activation_fn": Tanh}}
    cfg = TrainConfig(env_id=env_id).resolve()
    assert (cfg.n_envs, cfg.timesteps) == (own["n_envs"], own["n_timesteps"])
    assert cfg.hyperparams["batch_size"] == own["batch_size"]
    assert cfg.hyperparams["policy_kwargs"] == own["policy_kwargs"]
    assert cfg.hyperparams["gae_lambda"] == tuned.PPO["gae_lambda"]
    assert cfg.normalize == {"norm_obs": True, "norm_reward": True}
    # How a run of it is watched and ended: the id's run defaults, where no flag is given.
    assert (cfg.stop_success, cfg.eval_every, cfg.eval_episodes, cfg.keep_best) == \
        (1.0, 50_000, 200, False)
    given = TrainConfig(env_id=env_id, stop_success=0.0, eval_every=10_000,
                        keep_best=True).resolve()
    assert (given.stop_success, given.eval_every, given.eval_episodes, given.keep_best) == \
        (0.0, 10_000, 200, True)
    v0 = TrainConfig(env_id="rbenv/SatelliteReorient-v0").resolve()
    assert (v0.stop_success, v0.eval_every, v0.eval_episodes, v0.keep_best) == \
        (0.0, 200_000, 100, False)
    # The other scenes keep the settings measured on them.
    boom = TrainConfig(env_id=env_id, scene="boom-sat").resolve()
    assert boom.hyperparams["gamma"] == 0.99 and boom.timesteps == 1_500_000
    assert boom.hyperparams["policy_kwargs"] == {"net_arch": [64, 64], "log_std_init": -1.0}
    # Whole rollouts split into whole minibatches.
    assert (own["n_envs"] * own["n_steps"]) % own["batch_size"] == 0


V1_IDS = ("rbenv/SatelliteReorient-v1", "rbenv/SatelliteDetumble-v1", "rbenv/SatelliteTrack-v1")


@pytest.mark.parametrize(("env_id", "algo"), [
    (env_id, algo) for env_id in V1_IDS for algo in settings.get(env_id).id_settings
    if algo != "ppo"])
def test_an_ids_own_budget_reaches_train_the_zoo_and_the_suite_alike(env_id, algo):
    """A v1 id's measured off-policy budget lives in its training entry (id_settings) only:
    `rbenv train`'s default --timesteps, the RL Zoo file's n_timesteps and the suite's cell
    budget are that one number, and every other setting is still the shared dict's."""
    import importlib

    from rbenv.agents.training.config import TrainConfig, shipped_settings

    spec = settings.get(env_id)
    steps = spec.id_settings[algo]["n_timesteps"]
    zoo = importlib.import_module(f"rbenv.agents.zoo.{algo}").hyperparams[env_id]
    assert zoo == shipped_settings(algo, env_id) == spec.settings(algo)
    assert zoo["n_timesteps"] == steps == spec.timesteps(algo, "cubesat-12u")
    assert TrainConfig(algo=algo, env_id=env_id).resolve().timesteps == steps
    shared = {k: v for k, v in tuned.ALL[algo].items() if k != "n_timesteps"}
    assert {k: v for k, v in zoo.items() if k != "n_timesteps"} == shared
    assert spec.settings(algo) is not spec.settings(algo)  # a copy: a caller can't edit it


def test_a_v1_budget_differs_from_the_shared_one_where_it_was_measured():
    """The per-id numbers are not the shared default restated (that would be no tuning)."""
    spec = settings.get("rbenv/SatelliteReorient-v1")
    for algo in ("sac", "td3", "tqc", "crossq"):
        assert spec.timesteps(algo) != tuned.ALL[algo]["n_timesteps"]
    assert settings.get("rbenv/SatelliteReorient-v0").settings("sac") == tuned.SAC


@pytest.mark.parametrize("env_id", V1_IDS)
def test_every_v1_id_ships_a_measured_budget_for_every_off_policy_learner(env_id):
    assert set(settings.get(env_id).id_settings) - {"ppo"} == \
        {"sac", "td3", "tqc", "crossq"}


@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_reorient_v1_trains_sac_and_td3_with_many_envs_through_sbx_only(algo):
    """--engine sbx trains Reorient-v1's SAC and TD3 with the many-env recipe (tuned.MANY_ENVS)
    over the id's settings, and its own budget; the sb3 engine, the RL Zoo's file and v0 keep
    the shared recipe (32 envs, a quarter update per env step)."""
    import importlib

    from rbenv.agents.training.config import SBXConfig, TrainConfig

    env_id = "rbenv/SatelliteReorient-v1"
    fast = SBXConfig(algo=algo, env_id=env_id).resolve()
    assert fast.n_envs == tuned.MANY_ENVS["n_envs"] == 256
    assert fast.hyperparams["batch_size"] == 1024 and fast.hyperparams["gradient_steps"] == 16
    assert fast.hyperparams["policy_kwargs"] == {"net_arch": [64, 64]}
    assert fast.hyperparams["gradient_steps"] / fast.n_envs == 1 / 16  # updates per env step
    assert fast.hyperparams["learning_rate"] == tuned.ALL[algo]["learning_rate"]  # shared
    assert fast.timesteps == settings.get(env_id).engine_settings["sbx", algo]["n_timesteps"]
    for cfg in (TrainConfig(algo=algo, env_id=env_id).resolve(),
                SBXConfig(algo=algo, env_id="rbenv/SatelliteReorient-v0").resolve()):
        assert cfg.n_envs == 32 and cfg.hyperparams["gradient_steps"] / cfg.n_envs == 1 / 4
    zoo = importlib.import_module(f"rbenv.agents.zoo.{algo}").hyperparams[env_id]
    assert zoo["n_envs"] == 32


def test_engine_settings_must_name_an_algorithm_with_settings():
    from rbenv.agents.settings.table import TrainingSettings, register
    from rbenv.core.errors import InvalidParameterError

    for bad in ({("sbx", "ddpg"): {}}, {"sbx": {}}, {("sbx", "sac"): {"n_timesteps": 0}}):
        with pytest.raises(InvalidParameterError, match="engine_settings"):
            register(TrainingSettings(env_id="test/NoSuch-v0", baselines={"pd": "a.b:C"},
                                      hyperparams=tuned.ALL, engine_settings=bad))


@pytest.mark.parametrize("field, bad", [
    ("scene_settings", {("ddpg", "boom-sat"): {}}),
    ("scene_settings", {"ppo": {}}),
    ("scene_settings", {("ppo", "boom-sat"): 0.98}),
    ("run_defaults", {"ddpg": {"stop_success": 1.0}}),
    ("run_defaults", {"ppo": {"learning_rate": 1e-3}}),  # a model setting, not the run's
    ("run_defaults", {"ppo": 1.0}),
    ("torchrl", {"timesteps": 0}),
    ("torchrl", {"timesteps": 1.5e6}),
    ("torchrl", [("gamma", 0.98)]),
])
def test_scene_settings_and_run_defaults_are_checked_at_registration(field, bad):
    from rbenv.agents.settings.table import TrainingSettings, register
    from rbenv.core.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match=field):
        register(TrainingSettings(env_id="test/NoSuch-v0", baselines={"pd": "a.b:C"},
                                  hyperparams=tuned.ALL, **{field: bad}))


def test_an_ids_torchrl_settings_set_the_torchrl_run_under_the_callers():
    from rbenv.agents.settings.table import TrainingSettings, register, unregister
    from rbenv.agents.training.config import TorchRLConfig, TorchRLRunConfig
    from rbenv.core.errors import InvalidParameterError

    v1 = "rbenv/SatelliteReorient-v1"
    shipped = settings.get(v1).torchrl
    cfg = TorchRLRunConfig(env_id=v1).resolve()
    assert cfg.timesteps == shipped["timesteps"]
    assert {k: cfg.hyperparams[k] for k in shipped if k != "timesteps"} == \
        {k: v for k, v in shipped.items() if k != "timesteps"}
    mine = TorchRLRunConfig(env_id=v1, timesteps=65_536, hyperparams={"gamma": 0.95}).resolve()
    assert mine.timesteps == 65_536 and mine.hyperparams["gamma"] == 0.95
    assert mine.hyperparams["hidden"] == shipped["hidden"]
    plain = TorchRLRunConfig(env_id="rbenv/SatelliteReorient-v0").resolve()  # none shipped
    assert plain.timesteps == TorchRLConfig.timesteps
    assert plain.hyperparams["hidden"] == TorchRLConfig.hidden
    register(TrainingSettings(env_id="test/TorchRLTypo-v0", baselines={"pd": "a.b:C"},
                              hyperparams=tuned.ALL, torchrl={"n_steps": 32}))
    try:
        with pytest.raises(InvalidParameterError,
                           match=r"torchrl settings of test/TorchRLTypo-v0: \['n_steps'\]"):
            TorchRLRunConfig(env_id="test/TorchRLTypo-v0").resolve()
    finally:
        unregister("test/TorchRLTypo-v0")


def test_the_ids_run_defaults_reach_every_engine_that_has_the_field():
    from rbenv.agents.training.config import TorchRLRunConfig, TrainConfig
    from rbenv.agents.training.rllib import RLlibConfig

    v1 = "rbenv/SatelliteReorient-v1"
    watch = settings.get(v1).run_defaults["ppo"]
    for cls in (TrainConfig, RLlibConfig, TorchRLRunConfig):
        cfg = cls(env_id=v1).resolve()
        assert (cfg.eval_every, cfg.eval_episodes) == (watch["eval_every"],
                                                       watch["eval_episodes"]), cls
        assert getattr(cfg, "stop_success", watch["stop_success"]) == watch["stop_success"]
        assert cls(env_id=v1, eval_every=1000).resolve().eval_every == 1000  # the caller's wins
        plain = cls(env_id="rbenv/SatelliteReorient-v0").resolve()
        assert (plain.eval_every, plain.eval_episodes) == (200_000, 100), cls
