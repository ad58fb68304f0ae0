"""Every id x algorithm x engine x scene resolves to the numbers it resolved to on main at
8ef0698 (data/resolution_8ef0698.json, written by resolution.py before the recipes), except
the budgets that became the learning suite's measured ones, and the recipe's env options, which
RLlib and TorchRL now take as SB3 and SBX do (one source per number; CHANGELOG.md lists them)."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from rbenv.agents import settings

from tests.agents.settings.resolution import resolve_all

GOLDEN = json.loads((Path(__file__).parent / "data" / "resolution_8ef0698.json").read_text())
# The zoo's budgets that moved to the suite's (algo, id): (before, after).
ZOO_CHANGES = {("ppo", "rbenv/SatelliteDetumble-v0"): (2_000_000, 300_000),
               ("ppo", "rbenv/SatelliteDetumble-v1"): (2_000_000, 300_000),
               ("ppo", "rbenv/SatelliteReorient-v0"): (2_000_000, 1_000_000),
               ("sac", "rbenv/SatelliteDesaturate-v0"): (300_000, 200_000),
               ("sac", "rbenv/SatelliteDetumble-v0"): (300_000, 100_000),
               ("sac", "rbenv/SatelliteReorient-v0"): (300_000, 200_000),
               ("sac", "rbenv/SatelliteTrack-v0"): (300_000, 200_000)}
# Reorient-v0's SB3 PPO updates on cubesat-12u (Reorient-v1's), over the shared ones.
REORIENT_V0_12U = {"n_steps": 32, "batch_size": 4096, "n_epochs": 3, "learning_rate": 2e-3,
                   "gamma": 0.98, "policy_kwargs": {"net_arch": [64, 64], "log_std_init": -0.5,
                                                    "activation_fn": "tanh"}}
# Reorient-v0's own since 2026-12-07: 5 epochs and a [128, 128] network (where the [64, 64]
# of 3 epochs lost control on 10 of 3,000 validation episodes; shipped.REORIENT_V0_PPO_12U).
REORIENT_V0_12U_NOW = {"n_epochs": 5,
                       "policy_kwargs": {**REORIENT_V0_12U["policy_kwargs"],
                                         "net_arch": [128, 128]}}
# The zoo trains gym.make(env_id), the id's default scene, so it takes that scene's recipe: the
# ones set on cubesat-12u after validation (benchmarks.task_table, docs/results.md). Track-v1's
# budget there is 2 M again, as at 8ef0698; Track-v0's 3 M (SCENE_BUDGETS).
ZOO_SCENE_RECIPES = {
    ("ppo", "rbenv/SatelliteDetumble-v0"): {"gamma": 0.9,
                                            "env_kwargs": {"reward_weights": {"fuel": 1.0}}},
    ("ppo", "rbenv/SatelliteDetumble-v1"): {"gamma": 0.95},
    ("ppo", "rbenv/SatelliteTrack-v0"): {"n_timesteps": 3_000_000,
                                         "env_kwargs": {"reward_weights": {"fuel": 2.0}}},
    ("ppo", "rbenv/SatelliteTrack-v1"): {"env_kwargs": {"reward_weights": {"fuel": 3.0}}},
    ("ppo", "rbenv/SatelliteReorient-v1"): {
        "n_timesteps": 2_000_000,
        "env_kwargs": {"reward_weights": {"fuel": 2.0, "progress": 25.0, "failure": 100.0}}},
    ("ppo", "rbenv/SatelliteReorient-v0"): {
        "n_timesteps": 2_000_000, **REORIENT_V0_12U, **REORIENT_V0_12U_NOW, "n_envs": 256,
        "env_kwargs": {"reward_weights": {"fuel": 0.5, "progress": 25.0}}},
    ("ppo", "rbenv/SatelliteReorient-v2"): {
        "n_timesteps": 1_800_000, "n_epochs": 5,
        "policy_kwargs": {**REORIENT_V0_12U["policy_kwargs"], "net_arch": [128, 128]},
        "env_kwargs": {"reward_weights": {"time": 0.2, "fuel": 3.0}}}}
# Recipes keyed to one engine (Recipe(algo, engine, scene)), set after validation: Reorient-v1's
# SB3 PPO on cubesat-12u trains to 2 M steps on its own reward weights without the early stop,
# Reorient-v0's with Reorient-v1's updates, 2 M steps and its own reward weights
# (benchmarks.task_table, docs/performance.md); RLlib and TorchRL there keep theirs. The
# learning suite trains with SB3, so its budget moves too.
ENGINE_RECIPES = {
    "sb3/ppo/rbenv/SatelliteReorient-v0/cubesat-12u": {
        "timesteps": 2_000_000, "n_envs": 256,
        "hyperparams": {**REORIENT_V0_12U, **REORIENT_V0_12U_NOW, "gae_lambda": 0.95,
                        "clip_range": 0.2, "ent_coef": 0.0},
        "env_kwargs": {"reward_weights": {"fuel": 0.5, "progress": 25.0}}},
    "sb3/ppo/rbenv/SatelliteReorient-v1/cubesat-12u": {
        "timesteps": 2_000_000, "stop_success": 0.0, "eval_every": 500_000,
        "eval_episodes": 100,
        "env_kwargs": {"reward_weights": {"fuel": 2.0, "progress": 25.0, "failure": 100.0}}},
    # The main job: Reorient-v2's SB3 PPO on cubesat-12u (shipped.REORIENT_V2_PPO_12U).
    "sb3/ppo/rbenv/SatelliteReorient-v2/cubesat-12u": {
        "timesteps": 1_800_000,
        "hyperparams": {**REORIENT_V0_12U, "n_epochs": 5, "gae_lambda": 0.95,
                        "clip_range": 0.2, "ent_coef": 0.0,
                        "policy_kwargs": {**REORIENT_V0_12U["policy_kwargs"],
                                          "net_arch": [128, 128]}},
        "env_kwargs": {"reward_weights": {"time": 0.2, "fuel": 3.0}}}}
# Budgets of a scene's recipe set after validation, on every engine that takes the recipe's
# n_timesteps (sb3, rllib and the suite; torchrl has its own): algo/id/scene -> (8ef0698, now).
# Track-v0 on cubesat-12u: 3 M steps, where 2 M missed a validation episode on seed 1.
SCENE_BUDGETS = {"ppo/rbenv/SatelliteTrack-v0/cubesat-12u": (2_000_000, 3_000_000)}
SUITE_CHANGES = {"suite/ppo/rbenv/SatelliteReorient-v1/cubesat-12u": (600_000, 2_000_000),
                 "suite/ppo/rbenv/SatelliteReorient-v0/cubesat-12u": (1_000_000, 2_000_000),
                 "suite/ppo/rbenv/SatelliteReorient-v2/cubesat-12u": (2_000_000, 1_800_000),
                 **{f"suite/{k}": v for k, v in SCENE_BUDGETS.items()}}
# rbenv train combinations whose budget moved (118), or whose env options RLlib and TorchRL now
# take from the recipe (20: 10 id x scene pairs, 6 of them with a moved RLlib budget too),
# beside the 9 zoo entries. Track-v0's and Track-v1's PPO on cubesat-12u (sb3, rllib) moved to
# the suite's 1 M and back to 2 M with their own recipes; their regenerated entries match again.
# Reorient-v1's SB3 PPO on cubesat-12u and its suite budget (ENGINE_RECIPES, SUITE_CHANGES): 2.
# Track-v0's PPO on cubesat-12u, sb3, rllib and the suite (SCENE_BUDGETS): 3. Reorient-v0's
# suite budget on cubesat-12u (its sb3 entry had already moved, to the suite's 1 M): 1.
# Reorient-v2's SB3 PPO on cubesat-12u, the main job, and its suite budget: 2.
CHANGED = 140


@pytest.fixture(scope="module")
def now():
    return resolve_all()


def _expected(key: str) -> dict:
    """The golden value of ``key`` with the budget of one source: where main's ``rbenv train``
    default differed from the suite's budget, the suite's (sbx's own recipes, and torchrl's,
    kept)."""
    want = copy.deepcopy(GOLDEN[key])
    engine, algo, rest = key.split("/", 2)
    if engine in ("sb3", "rllib") or (engine == "sbx" and want["timesteps"] ==
                                      GOLDEN[f"sb3/{algo}/{rest}"]["timesteps"]):
        want["timesteps"] = GOLDEN[f"suite/{algo}/{rest}"]
        if f"{algo}/{rest}" in SCENE_BUDGETS:
            want["timesteps"] = SCENE_BUDGETS[f"{algo}/{rest}"][1]
    if engine in ("rllib", "torchrl"):  # the recipe's env options reach every engine
        want["env_kwargs"] = GOLDEN[f"sb3/{algo}/{rest}"]["env_kwargs"]
        if "learner" in want:
            want["learner"]["env_kwargs"] = want["env_kwargs"]
    want.update(copy.deepcopy(ENGINE_RECIPES.get(key, {})))
    return want


def test_every_combination_is_resolved(now):
    assert sorted(now) == sorted(GOLDEN)
    assert len(now) == 761  # 733 at 8ef0698, and Desaturate-v1's 28 (a new id, added as resolved)
    ids = {key.split("/", 2)[2].rsplit("/", 1)[0] for key in now if not key.startswith("zoo/")}
    assert ids == {entry.env_id for entry in settings.entries()}


def test_the_suite_budgets_are_unchanged(now):
    suite = [k for k in GOLDEN if k.startswith("suite/")]
    assert len(suite) == 270  # 260, and Desaturate-v1's 10 (5 algorithms, 2 scenes)
    want = {k: GOLDEN[k] for k in suite}
    for key, (before, after) in SUITE_CHANGES.items():
        assert want[key] == before
        want[key] = after
    assert {k: now[k] for k in suite} == want


@pytest.mark.parametrize("engine", ["sb3", "sbx", "rllib", "torchrl"])
def test_each_engine_resolves_to_main_but_the_one_source_budgets(now, engine):
    keys = [k for k in GOLDEN if k.startswith(engine + "/")]
    assert keys
    for key in keys:
        assert now[key] == _expected(key), key


def test_every_engine_takes_the_recipes_env_options(now):
    """One source: RLlib's and TorchRL's env options on each id and scene are SB3's (the wheel
    scenes' failure weight, InnoCube's action mode, boom-sat tracking's fuel weight), but where
    SB3 has a recipe of its own (ENGINE_RECIPES): there they keep the general recipe's."""
    differ = 0
    for key in (k for k in now if k.split("/")[0] in ("rllib", "torchrl")):
        sb3_key = "sb3/" + key.split("/", 1)[1]
        if sb3_key in ENGINE_RECIPES:
            assert now[key]["env_kwargs"] == GOLDEN[key]["env_kwargs"] == {}, key
            continue
        sb3 = now[sb3_key]["env_kwargs"]
        assert now[key]["env_kwargs"] == sb3, key
        differ += GOLDEN[key]["env_kwargs"] != sb3
    assert differ > 0  # main left them out on some scenes


def test_rbenv_train_trains_the_suite_budget(now):
    """One source: SB3's default budget is the suite's, on every id, algorithm and scene."""
    for key in (k for k in now if k.startswith("sb3/")):
        assert now[key]["timesteps"] == now["suite/" + key.split("/", 1)[1]], key


def test_zoo_tables_change_only_in_the_listed_budgets_and_scene_recipes(now):
    want = copy.deepcopy({k: v for k, v in GOLDEN.items() if k.startswith("zoo/")})
    for (algo, env_id), (before, after) in ZOO_CHANGES.items():
        assert want[f"zoo/{algo}"][env_id]["n_timesteps"] == before
        want[f"zoo/{algo}"][env_id]["n_timesteps"] = after
    for (algo, env_id), fields in ZOO_SCENE_RECIPES.items():
        want[f"zoo/{algo}"][env_id].update(copy.deepcopy(fields))
    assert {k: now[k] for k in want} == want


def test_the_count_of_changes(now):
    moved = sum(now[k] != GOLDEN[k] for k in GOLDEN if not k.startswith("zoo/"))
    listed = {**ZOO_CHANGES, **ZOO_SCENE_RECIPES}
    zoo = sum(now[f"zoo/{a}"][i] != GOLDEN[f"zoo/{a}"][i] for a, i in listed)
    assert (moved, zoo) == (CHANGED, len(listed))


def test_the_main_job_is_reorient_v2_ppo_on_its_own_recipe(now):
    from rbenv.agents.training.config import TrainConfig

    cfg = TrainConfig().resolve()
    key = "sb3/ppo/rbenv/SatelliteReorient-v2/cubesat-12u"
    assert (cfg.env_id, cfg.algo, cfg.scene, cfg.timesteps) == \
        ("rbenv/SatelliteReorient-v2", "ppo", "cubesat-12u", 1_800_000)
    assert GOLDEN[key]["timesteps"] == 2_000_000  # 8ef0698's
    assert now[key] == _expected(key)
