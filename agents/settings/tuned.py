"""The tuned settings of each algorithm, in RL Baselines3 Zoo's format, shared by the ids.

The training entries (:mod:`rbenv.agents.settings.shipped`) start every shipped id's recipes
from these dicts (:func:`recipes`); the zoo files (``rbenv.agents.zoo.ppo``, ...) and ``rbenv
train`` read the entries.
"""

from __future__ import annotations

from rbenv.agents.settings.off_policy import recipe
from rbenv.agents.settings.table import Recipe
from rbenv.core.errors import InvalidParameterError

# rbenv train's PPO: 64 native sub-envs, VecNormalize, 2 M steps (the README's main job).
PPO = {
    "policy": "MlpPolicy",
    "n_envs": 64,
    "n_timesteps": 2_000_000,
    "normalize": True,
    "n_steps": 64,
    "batch_size": 1024,
    "n_epochs": 5,
    "learning_rate": 5e-4,
    "gamma": 0.99,
    "gae_lambda": 0.95,
    "clip_range": 0.2,
    "ent_coef": 0.0,
    "policy_kwargs": {"net_arch": [128, 128], "log_std_init": -1.0},
    # Log the task's success flag in monitor.csv beside the return.
    "monitor_kwargs": {"info_keywords": ("is_success",)},
}

# The off-policy learners: the shared recipe (rbenv.agents.settings.off_policy), measured on
# SatelliteReorient-v0/cubesat-12u (docs/off-policy.md). A task entry gives an id its own
# measured n_timesteps (recipes() below); the rest is shared.
SAC = recipe()
TD3 = recipe(noise_type="normal", noise_std=0.1)
# TQC: a 200k-step budget (99.7 % held out at 169k on Reorient-v0; a TQC step costs ~2x SAC's).
TQC = recipe(n_timesteps=200_000)
# CrossQ has no target network (no tau); its critics are [256, 256], not sb3-contrib's default
# 1024 x 1024, which ran at 43 env-steps/s here.
CROSSQ = recipe(tau=None, policy_kwargs={"net_arch": [256, 256]})

# The off-policy learners' many-env recipe on a CPU (FastTD3/FastSAC's: many envs, few and
# large updates), over RECIPE: 256 native sub-envs, 16 gradient steps of batch 1024 per vector
# step (1/16 update per env step against RECIPE's 1/4; a quarter of the updates per sample,
# each of twice the batch), [64, 64] networks (an update of batch 1024 costs about 4 ms of
# CPU in SBX, against about 33 ms at [256, 256]). Reorient-v1's SAC and TD3 use it with
# rbenv train --engine sbx (shipped.REORIENT_V1_SBX; docs/performance.md has the measurements).
MANY_ENVS = {"n_envs": 256, "batch_size": 1024, "gradient_steps": 16,
             "policy_kwargs": {"net_arch": [64, 64]}}

# PPO's training env options on the wheel scenes (the env_kwargs of the entries' scene recipes).
# With the default failure weight (25) PPO learns to spin the bus past the rate limit within ~7
# steps and end the episode: the weak wheels (3.2 mN·m on cubesat-6u-rw) need 40–80 s for a
# manoeuvre whose per-step terms cost more than failing. Held out, 0–14 % with 25; with 200:
# reorient 97.0 % (6u-rw) and 99.8 % (12u-rw), v1 99.8 %, track 100 %, detumble 100 %
# (docs/results.md).
WHEELS_FAILURE = {"reward_weights": {"failure": 200.0}}

# PPO's training of SatelliteTrack-v1 on boom-sat. v1's fuel weight (2.5) was set on
# cubesat-12u, where the PD holds the track with 0.85 g; on boom-sat it needs 17.3 g, and with
# 2.5 PPO learns to save propellant instead of tracking (1.0 % held out, 3.1 g, 1 M steps).
# With 0.25: 95.8 % held out (PD 83.0 %), 24.1 g (docs/learning-suite.md).
BOOM_TRACK_FUEL = {"reward_weights": {"fuel": 0.25}}

# TorchRL's PPO learner (rbenv train --engine torchrl) where an id has no recipe of its own,
# in RL Zoo's names (translated by rbenv.agents.training.config.torchrl_fields): chosen for the
# default scene on a CPU (docs/torch.md). Its networks are two tanh layers of net_arch's width
# and it always normalises observations and scales rewards.
TORCHRL_PPO = {"n_envs": 256, "n_timesteps": 800_000, "n_steps": 64, "batch_size": 2048,
               "n_epochs": 5, "learning_rate": 1e-3, "gamma": 0.99, "gae_lambda": 0.95,
               "clip_range": 0.2, "policy_kwargs": {"net_arch": [128, 128], "log_std_init": -1.0}}

# algorithm -> settings: what every shipped task entry starts from.
ALL = {"ppo": PPO, "sac": SAC, "td3": TD3, "tqc": TQC, "crossq": CROSSQ}


def recipes(**own: dict) -> dict:
    """The shared recipes of a task entry: ``Recipe(algo)`` for each algorithm of :data:`ALL`
    and ``Recipe("ppo", "torchrl")`` (:data:`TORCHRL_PPO`), each with the id's ``own[algo]``
    (or ``own["torchrl"]``) over it: ``recipes(sac={"n_timesteps": 150_000})``. New dicts."""
    unknown = sorted(set(own) - {*ALL, "torchrl"})
    if unknown:
        raise InvalidParameterError(f"recipes: {unknown} are not algorithms of tuned.ALL nor "
                                    "'torchrl'")
    table = {Recipe(algo): {**settings, **own.get(algo, {})} for algo, settings in ALL.items()}
    table[Recipe("ppo", "torchrl")] = {**TORCHRL_PPO, **own.get("torchrl", {})}
    return table


def budgets(**timesteps: int) -> dict:
    """Each named algorithm's measured training budget on an id, for :func:`recipes`:
    ``budgets(sac=150_000)`` → ``{"sac": {"n_timesteps": 150000}}``."""
    return {algo: {"n_timesteps": int(steps)} for algo, steps in timesteps.items()}
