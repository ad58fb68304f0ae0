"""Each number has one source, the id's recipes (rbenv.agents.settings; the shared dicts in
rbenv.agents.settings.tuned): `rbenv train` (every engine), the suite and the RL Zoo file read
them; none keeps a copy (issue 21 item 2, issue 42 item 3)."""

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


def test_a_change_in_a_recipe_reaches_every_reader(monkeypatch):
    """Change an id's PPO recipe in place: SB3's, RLlib's and the zoo's defaults follow (they
    read the table, not a copy)."""
    from rbenv.agents.settings import Recipe
    from rbenv.agents.training.config import shipped_settings
    from rbenv.agents.training.rllib import RLlibConfig

    for env_id in ("rbenv/SatelliteReorient-v0", "rbenv/SatelliteReorient-v1"):
        ppo = settings.get(env_id).recipes[Recipe("ppo")]
        monkeypatch.setitem(ppo, "learning_rate", 1.234e-4)
        monkeypatch.setitem(ppo, "n_epochs", 7)
        monkeypatch.setitem(ppo, "gae_lambda", 0.9)
        assert shipped_settings("ppo", env_id)["learning_rate"] == 1.234e-4
        cfg = RLlibConfig(env_id=env_id).resolve()
        assert (cfg.hyperparams["lr"], cfg.hyperparams["num_epochs"]) == (1.234e-4, 7)
        assert cfg.hyperparams["lambda_"] == 0.9
        assert cfg.hyperparams["train_batch_size_per_learner"] == ppo["n_envs"] * ppo["n_steps"]
        assert cfg.model["fcnet_hiddens"] == ppo["policy_kwargs"]["net_arch"]
        assert cfg.log_std_init == ppo["policy_kwargs"]["log_std_init"]
        # The zoo reads SB3's recipe on the default scene; v0's sets its own epochs there.
        own = settings.get(env_id).recipes.get(Recipe("ppo", "sb3", scene="cubesat-12u"), {})
        if "n_epochs" in own:
            monkeypatch.setitem(own, "n_epochs", 7)
        assert settings.zoo_hyperparams("ppo")[env_id]["n_epochs"] == 7


def test_the_main_job_trains_reorient_v2_on_its_recipe_and_v1_has_its_own_reward_weights():
    """``rbenv train`` with no arguments: Reorient-v2 (rbenv.ENV_ID) on cubesat-12u with SB3,
    v1's PPO updates with 5 epochs and a [128, 128] network to 1.8 M steps, no early stop, time
    and fuel weights 0.2 and 3.0, the policy acting with its mode (REORIENT_V2_PPO_12U);
    Reorient-v1 on cubesat-12u trains v1's updates to 2 M steps on its own recipe's reward
    weights; v2 on another scene, or with another engine, keeps v1's updates to 2 M."""
    from rbenv.agents.settings import shipped
    from rbenv.agents.training.config import TorchRLRunConfig, TrainConfig

    import rbenv

    assert rbenv.ENV_ID == "rbenv/SatelliteReorient-v2"
    cfg = TrainConfig().resolve()
    main = shipped.REORIENT_V2_PPO_12U
    assert (cfg.env_id, cfg.algo, cfg.scene, cfg.timesteps) == \
        (rbenv.ENV_ID, "ppo", "cubesat-12u", 1_800_000)
    assert (cfg.stop_success, cfg.policy_action) == (0.0, "mode")
    assert cfg.env_kwargs == {"reward_weights": {"time": 0.2, "fuel": 3.0}}
    assert cfg.hyperparams["policy_kwargs"] == main["policy_kwargs"] == {
        **shipped.REORIENT_V1_PPO["policy_kwargs"], "net_arch": [128, 128]}
    assert cfg.hyperparams["n_epochs"] == 5
    assert {k: cfg.hyperparams[k] for k in ("n_steps", "batch_size", "learning_rate", "gamma")} \
        == {k: shipped.REORIENT_V1_PPO[k] for k in ("n_steps", "batch_size", "learning_rate",
                                                      "gamma")}
    other = TrainConfig(scene="microsat-100kg").resolve()
    assert (other.policy_action, other.hyperparams["n_epochs"]) == ("auto", 3)
    torchrl = TorchRLRunConfig(engine="torchrl").resolve()
    assert "reward_weights" not in torchrl.env_kwargs and torchrl.policy_action == "auto"
    v1 = TrainConfig(env_id="rbenv/SatelliteReorient-v1").resolve()
    assert (v1.timesteps, v1.stop_success, v1.policy_action) == (2_000_000, 0.0, "auto")
    assert v1.env_kwargs == {"reward_weights": {"fuel": 2.0, "progress": 25.0, "failure": 100.0}}
    assert v1.hyperparams == {**cfg.hyperparams, "n_epochs": 3,
                              "policy_kwargs": shipped.REORIENT_V1_PPO["policy_kwargs"]}


def test_reorient_v1_ppo_settings_reach_train_and_the_zoo():
    """Reorient-v1's own PPO values (its fast path, docs/performance.md) are its general recipe;
    on cubesat-12u, the default scene, SB3 (`rbenv train`) and the RL Zoo file train them to
    2 M steps on the 12u recipe's reward weights, without the early stop; the keys neither
    sets are the shared dict's."""
    import importlib

    from rbenv.agents.settings import shipped
    from rbenv.agents.training.config import TrainConfig, shipped_settings

    env_id = "rbenv/SatelliteReorient-v1"
    own, scene = shipped.REORIENT_V1_PPO, shipped.REORIENT_V1_PPO_12U
    zoo = importlib.import_module("rbenv.agents.zoo.ppo").hyperparams[env_id]
    run = {"stop_success": 1.0, "eval_every": 50_000, "eval_episodes": 200}
    assert shipped_settings("ppo", env_id) == {**tuned.PPO, **own, "run": run}
    weights = {"reward_weights": {"fuel": 2.0, "progress": 25.0, "failure": 100.0}}
    assert shipped_settings("ppo", env_id, "sb3", "cubesat-12u") == {
        **tuned.PPO, **own, **scene, "env_kwargs": weights,
        "run": {"stop_success": 0.0, "eval_every": 500_000, "eval_episodes": 100}}
    # The zoo gets SB3's dict without rbenv's run defaults, with the activation's name made
    # the class SB3 builds.
    from rbenv.agents.policies.activations import Tanh

    assert own["policy_kwargs"]["activation_fn"] == "tanh"
    assert zoo == {**tuned.PPO, **own, "n_timesteps": 2_000_000, "env_kwargs": weights,
                   "policy_kwargs": {**own["policy_kwargs"], "activation_fn": Tanh}}
    cfg = TrainConfig(env_id=env_id).resolve()
    assert (cfg.scene, cfg.n_envs, cfg.timesteps) == ("cubesat-12u", own["n_envs"], 2_000_000)
    assert cfg.env_kwargs == weights
    assert cfg.hyperparams["batch_size"] == own["batch_size"]
    assert cfg.hyperparams["policy_kwargs"] == own["policy_kwargs"]
    assert cfg.hyperparams["gae_lambda"] == tuned.PPO["gae_lambda"]
    assert "run" not in cfg.hyperparams
    assert cfg.normalize == {"norm_obs": True, "norm_reward": True}
    # How a run of it is watched and ended: the recipe's run defaults, where no flag is given.
    assert (cfg.stop_success, cfg.eval_every, cfg.eval_episodes, cfg.keep_best) == \
        (0.0, 500_000, 100, False)
    # The fast recipe by its flags (docs/performance.md, "What ships: Reorient-v1's own PPO"):
    # the env's own reward weights, 600k steps, the early stop.
    fast = TrainConfig(env_id=env_id, recipe_env_kwargs=False, timesteps=600_000,
                       stop_success=1.0, eval_every=50_000, eval_episodes=200).resolve()
    assert (fast.timesteps, fast.stop_success, fast.eval_every, fast.eval_episodes) == \
        (own["n_timesteps"], *run.values())
    assert fast.env_kwargs == {} and fast.hyperparams == cfg.hyperparams
    given = TrainConfig(env_id=env_id, stop_success=1.0, eval_every=10_000,
                        keep_best=True).resolve()
    assert (given.stop_success, given.eval_every, given.eval_episodes, given.keep_best) == \
        (1.0, 10_000, 100, True)
    v0 = TrainConfig(env_id="rbenv/SatelliteReorient-v0").resolve()
    assert (v0.stop_success, v0.eval_every, v0.eval_episodes, v0.keep_best) == \
        (0.0, 200_000, 100, False)
    # The other scenes keep the settings measured on them; boom-sat its measured budget.
    boom = TrainConfig(env_id=env_id, scene="boom-sat").resolve()
    assert boom.hyperparams["gamma"] == 0.99 and boom.timesteps == 2_000_000
    assert boom.hyperparams["policy_kwargs"] == {"net_arch": [64, 64], "log_std_init": -1.0}
    assert (boom.stop_success, boom.env_kwargs) == (1.0, {})
    # RLlib on cubesat-12u keeps the fast recipe: the 12u recipe is SB3's alone.
    from rbenv.agents.training.rllib import RLlibConfig

    rllib = RLlibConfig(env_id=env_id).resolve()
    assert (rllib.scene, rllib.timesteps, rllib.env_kwargs) == ("cubesat-12u", 600_000, {})
    # Whole rollouts split into whole minibatches.
    assert (own["n_envs"] * own["n_steps"]) % own["batch_size"] == 0


V1_IDS = ("rbenv/SatelliteReorient-v1", "rbenv/SatelliteDetumble-v1", "rbenv/SatelliteTrack-v1")
OFF_POLICY = ("sac", "td3", "tqc", "crossq")


@pytest.mark.parametrize(("env_id", "algo"), [
    (env_id, algo) for env_id in V1_IDS for algo in OFF_POLICY])
def test_an_ids_own_budget_reaches_train_the_zoo_and_the_suite_alike(env_id, algo):
    """A v1 id's measured off-policy budget is one number of its recipe: `rbenv train`'s
    default --timesteps, the RL Zoo file's n_timesteps and the suite's cell budget, and every
    other setting is still the shared dict's."""
    import importlib

    from rbenv.agents.training import suite
    from rbenv.agents.training.config import TrainConfig, shipped_settings

    spec = settings.get(env_id)
    steps = spec.recipe(algo)["n_timesteps"]
    zoo = importlib.import_module(f"rbenv.agents.zoo.{algo}").hyperparams[env_id]
    assert zoo == shipped_settings(algo, env_id) == spec.recipe(algo)
    assert zoo["n_timesteps"] == steps == suite.default_timesteps(algo, env_id, "cubesat-12u")
    assert TrainConfig(algo=algo, env_id=env_id).resolve().timesteps == steps
    shared = {k: v for k, v in tuned.ALL[algo].items() if k != "n_timesteps"}
    assert {k: v for k, v in zoo.items() if k != "n_timesteps"} == shared
    assert steps != tuned.ALL[algo]["n_timesteps"]  # measured, not the shared one restated
    assert spec.recipe(algo) is not spec.recipe(algo)  # a copy: a caller can't edit it


def test_a_budget_reaches_train_the_suite_and_the_zoo_as_one_number():
    """One source per number: the v0 ids' PPO and SAC budgets, and a scene's, are the same
    for `rbenv train`, the suite and the zoo."""
    import importlib

    from rbenv.agents.training import suite
    from rbenv.agents.training.config import TrainConfig

    for env_id, algo, scene, steps in (
            ("rbenv/SatelliteReorient-v0", "ppo", "cubesat-12u", 2_000_000),
            ("rbenv/SatelliteReorient-v0", "ppo", "microsat-100kg", 1_000_000),
            ("rbenv/SatelliteReorient-v0", "sac", "cubesat-12u", 200_000),
            ("rbenv/SatelliteReorient-v0", "ppo", "boom-sat", 4_000_000),
            ("rbenv/SatelliteDetumble-v1", "ppo", "cubesat-12u", 300_000),
            ("rbenv/SatelliteReorient-v1", "ppo", "boom-sat", 2_000_000)):
        assert TrainConfig(algo=algo, env_id=env_id, scene=scene).resolve().timesteps == \
            suite.default_timesteps(algo, env_id, scene) == steps
        if scene == "cubesat-12u":
            zoo = importlib.import_module(f"rbenv.agents.zoo.{algo}").hyperparams[env_id]
            assert zoo["n_timesteps"] == steps


@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_reorient_v1_trains_sac_and_td3_with_many_envs_through_sbx_only(algo):
    """--engine sbx trains Reorient-v1's SAC and TD3 with the many-env recipe (tuned.MANY_ENVS)
    over the id's settings, and its own budget; the sb3 engine, the RL Zoo's file and v0 keep
    the shared recipe (32 envs, a quarter update per env step)."""
    import importlib

    from rbenv.agents.settings import Recipe
    from rbenv.agents.training.config import TrainConfig

    env_id = "rbenv/SatelliteReorient-v1"
    fast = TrainConfig(engine="sbx", algo=algo, env_id=env_id).resolve()
    assert fast.n_envs == tuned.MANY_ENVS["n_envs"] == 256
    assert fast.hyperparams["batch_size"] == 1024 and fast.hyperparams["gradient_steps"] == 16
    assert fast.hyperparams["policy_kwargs"] == {"net_arch": [64, 64]}
    assert fast.hyperparams["gradient_steps"] / fast.n_envs == 1 / 16  # updates per env step
    assert fast.hyperparams["learning_rate"] == tuned.ALL[algo]["learning_rate"]  # shared
    assert fast.timesteps == settings.get(env_id).recipes[Recipe(algo, "sbx")]["n_timesteps"]
    for cfg in (TrainConfig(algo=algo, env_id=env_id).resolve(),
                TrainConfig(engine="sbx", algo=algo,
                            env_id="rbenv/SatelliteReorient-v0").resolve()):
        assert cfg.n_envs == 32 and cfg.hyperparams["gradient_steps"] / cfg.n_envs == 1 / 4
    zoo = importlib.import_module(f"rbenv.agents.zoo.{algo}").hyperparams[env_id]
    assert zoo["n_envs"] == 32


def _entry(recipes: dict):
    from rbenv.agents.settings.table import TrainingSettings

    return TrainingSettings(env_id="test/NoSuch-v0", baselines={"pd": "a.b:C"},
                            recipes=recipes)


def test_recipes_merge_from_the_general_to_the_specific():
    """(algo) <- (algo, scene) <- (algo, engine) <- (algo, engine, scene); env_kwargs and run
    key by key, every other key replaced whole."""
    from rbenv.agents.settings import Recipe

    e = _entry({Recipe("ppo"): {"a": 1, "b": 1, "c": 1, "d": 1, "env_kwargs": {"x": 1},
                                "policy_kwargs": {"net_arch": [8], "log_std_init": 0.0}},
                Recipe("ppo", scene="s"): {"b": 2, "c": 2, "d": 2, "env_kwargs": {"y": 2},
                                           "policy_kwargs": {"net_arch": [4]}},
                Recipe("ppo", "e"): {"c": 3, "d": 3, "run": {"eval_every": 3}},
                Recipe("ppo", "e", "s"): {"d": 4, "env_kwargs": {"x": 4}}})
    assert e.recipe("ppo", "e", "s") == {"a": 1, "b": 2, "c": 3, "d": 4,
                                         "env_kwargs": {"x": 4, "y": 2},
                                         "policy_kwargs": {"net_arch": [4]},
                                         "run": {"eval_every": 3}}
    assert e.recipe("ppo", "e")["d"] == 3 and e.recipe("ppo", scene="s")["c"] == 2
    assert e.recipe("ppo", "other", "s")["c"] == 2
    assert e.recipe("ppo") == e.recipes[Recipe("ppo")]


@pytest.mark.parametrize("recipes, match", [
    ({}, r"no Recipe\('ppo'\)"),
    ({"ppo": {"n_timesteps": 1}}, r"no Recipe\('ppo'\)"),
    ({"RECIPE": {"n_timesteps": 1}, ("sbx", "sac"): {}}, "must map Recipe"),
    ({"RECIPE": {"n_timesteps": 1}, "ddpg": {}}, r"'ddpg' has no general recipe"),
    ({"RECIPE": {"n_timesteps": 1}, "sbx-sac": {"n_timesteps": 0}}, "n_timesteps'\\] must"),
    ({"RECIPE": {"n_timesteps": 1}, "ppo-boom": 0.98}, "must map Recipe"),
    ({"RECIPE": {"n_timesteps": 1, "run": {"learning_rate": 1e-3}}}, r"not run defaults"),
    ({"RECIPE": {"n_timesteps": 1, "run": 1.0}}, r"\['run'\] must be a dict"),
    ({"RECIPE": {"n_timesteps": 1, "env_kwargs": [("a", 1)]}}, r"\['env_kwargs'\] must"),
    ({"RECIPE": {"n_timesteps": 1.5e6}}, r"n_timesteps'\] must be a positive int"),
    ({"RECIPE": {}}, r"n_timesteps'\] must be a positive int"),
])
def test_recipes_are_checked_at_registration(recipes, match):
    from rbenv.agents.settings import Recipe
    from rbenv.agents.settings.table import register
    from rbenv.core.errors import InvalidParameterError

    keys = {"RECIPE": Recipe("ppo"), "ddpg": Recipe("ddpg", scene="boom-sat"),
            "sbx-sac": Recipe("sac", "sbx"), "ppo-boom": Recipe("ppo", scene="boom-sat")}
    table = {Recipe("sac"): {"n_timesteps": 1}} if "sbx-sac" in recipes else {}
    table.update({keys.get(k, k) if isinstance(k, str) else k: v for k, v in recipes.items()})
    with pytest.raises(InvalidParameterError, match=match):
        register(_entry(table))


def test_a_recipe_key_is_checked():
    from rbenv.agents.settings import Recipe
    from rbenv.core.errors import InvalidParameterError

    for bad, field in (({"algo": ""}, "algo"), ({"algo": None}, "algo"),
                       ({"algo": "ppo", "engine": 3}, "engine"),
                       ({"algo": "ppo", "scene": ""}, "scene")):
        with pytest.raises(InvalidParameterError, match=f"Recipe.{field} must be"):
            Recipe(**bad)


def test_an_ids_torchrl_recipe_sets_the_torchrl_run_under_the_callers():
    from rbenv.agents.settings import Recipe, shipped
    from rbenv.agents.settings.table import TrainingSettings, register, unregister
    from rbenv.agents.training.config import TorchRLConfig, TorchRLRunConfig
    from rbenv.core.errors import InvalidParameterError

    v1 = "rbenv/SatelliteReorient-v1"
    own = shipped.REORIENT_V1_TORCHRL
    cfg = TorchRLRunConfig(env_id=v1).resolve()
    assert cfg.timesteps == own["n_timesteps"] == 1_200_000
    assert {k: cfg.hyperparams[k] for k in own if k != "n_timesteps"} == \
        {k: v for k, v in own.items() if k != "n_timesteps"}
    learner = cfg.learner("cpu")
    assert (learner.num_envs, learner.rollout, learner.minibatch, learner.epochs, learner.lr,
            learner.gamma, learner.hidden, learner.log_std_init) == \
        (256, 32, 4096, 3, 2e-3, 0.98, 64, -0.5)
    mine = TorchRLRunConfig(env_id=v1, timesteps=65_536, hyperparams={
        "gamma": 0.95, "policy_kwargs": {"net_arch": [32, 32]}}).resolve()
    assert mine.timesteps == 65_536 and mine.hyperparams["gamma"] == 0.95
    assert mine.learner("cpu").hidden == 32 and mine.learner("cpu").log_std_init == -0.5
    plain = TorchRLRunConfig(env_id="rbenv/SatelliteReorient-v0").resolve()
    assert plain.timesteps == TorchRLConfig.timesteps == tuned.TORCHRL_PPO["n_timesteps"]
    assert plain.learner("cpu").hidden == TorchRLConfig.hidden == 128
    with pytest.raises(InvalidParameterError, match=r"\['rollout'\] are not --engine torchrl"):
        TorchRLRunConfig(env_id=v1, hyperparams={"rollout": 32}).resolve()
    with pytest.raises(InvalidParameterError, match=r"net_arch must be two hidden layers"):
        TorchRLRunConfig(env_id=v1, hyperparams={"policy_kwargs": {"net_arch": [64]}}).resolve()
    register(TrainingSettings(env_id="test/TorchRLBare-v0", baselines={"pd": "a.b:C"},
                              recipes={Recipe("ppo"): {"n_timesteps": 4096}}))
    try:
        with pytest.raises(InvalidParameterError, match=r"torchrl recipe of "
                           r"test/TorchRLBare-v0 .* has no \['n_envs'"):
            TorchRLRunConfig(env_id="test/TorchRLBare-v0").resolve()
    finally:
        unregister("test/TorchRLBare-v0")


def test_the_ids_run_defaults_reach_every_engine_that_has_the_field():
    from rbenv.agents.training.config import TorchRLRunConfig, TrainConfig
    from rbenv.agents.training.rllib import RLlibConfig

    v1 = "rbenv/SatelliteReorient-v1"
    for cls in (TrainConfig, RLlibConfig, TorchRLRunConfig):
        cfg = cls(env_id=v1).resolve()
        # The engine's recipe on the default scene (SB3's is keyed to sb3: no early stop).
        watch = settings.get(v1).recipe("ppo", cfg.engine, cfg.scene)["run"]
        assert (cfg.eval_every, cfg.eval_episodes) == (watch["eval_every"],
                                                       watch["eval_episodes"]), cls
        assert getattr(cfg, "stop_success", watch["stop_success"]) == watch["stop_success"]
        assert cls(env_id=v1, eval_every=1000).resolve().eval_every == 1000  # the caller's wins
        plain = cls(env_id="rbenv/SatelliteReorient-v0").resolve()
        assert (plain.eval_every, plain.eval_episodes) == (200_000, 100), cls


def test_the_packages_docstring_example_runs():
    """agents/settings/__init__.py's example is valid code: it registers, and the recipe
    merges as the docstring says."""
    import textwrap

    doc = settings.__doc__
    block = doc.split("::\n\n", 1)[1].split("\n\n")
    code = textwrap.dedent("\n\n".join(b for b in block[:2] if b.startswith("    ")))
    assert "settings.register(" in code
    try:
        exec(compile(code, "agents/settings/__init__.py", "exec"), {})
        mine = settings.get("myorg/PointSun-v0")
        assert mine.recipe("ppo")["n_timesteps"] == 500_000
        assert mine.recipe("ppo", "sb3", "boom-sat")["n_timesteps"] == 2_000_000
        assert mine.recipe("ppo", "torchrl", "boom-sat")["n_timesteps"] == \
            tuned.TORCHRL_PPO["n_timesteps"]
    finally:
        settings.unregister("myorg/PointSun-v0")


def test_settings_lookup_by_a_task_entry_names_the_type_and_the_id_to_pass():
    from rbenv.core.errors import InvalidParameterError

    from rbenv.envs import registry

    spec = registry.get("rbenv/SatelliteReorient-v2")
    with pytest.raises(InvalidParameterError,
                       match=r"env_id must be a Gymnasium id string .* got TaskSpec .* "
                             r"pass its \.env_id, 'rbenv/SatelliteReorient-v2'"):
        settings.get(spec)
    with pytest.raises(InvalidParameterError, match=r"got int 3$"):
        settings.get(3)
