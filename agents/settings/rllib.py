"""RLlib's names for the shipped PPO settings: ``rbenv train --engine rllib`` reads these.

The numbers are the id's PPO recipe for ``--engine rllib`` (zoo format:
:meth:`rbenv.agents.settings.TrainingSettings.recipe`), renamed here and nowhere else, so SB3
and RLlib PPO train with one set of settings. Only what
RLlib needs and SB3 leaves at a default is written here: SB3's gradient-norm limit (0.5) and
its unclipped value loss (RLlib clips it unless ``vf_clip_param`` is huge), and SB3's
``MlpPolicy`` activation (tanh) with separate policy and value networks and a
state-independent log std (with a state-dependent one the policy learns to act through its
noise, and its mean, the deterministic policy, fails).
"""

from __future__ import annotations

SB3_MAX_GRAD_NORM = 0.5  # SB3 PPO's default max_grad_norm
SB3_LOG_STD_INIT = 0.0  # SB3's default log_std_init


def ppo(settings: dict) -> dict:
    """RLlib PPO ``training(...)`` arguments from zoo-format PPO ``settings``: one update per
    ``n_envs × n_steps`` env steps, minibatches of ``batch_size``, the same epochs, learning
    rate, discount, GAE λ, clipping and entropy coefficient."""
    return {"train_batch_size_per_learner": settings["n_envs"] * settings["n_steps"],
            "minibatch_size": settings["batch_size"], "num_epochs": settings["n_epochs"],
            "lr": settings["learning_rate"], "gamma": settings["gamma"],
            "lambda_": settings["gae_lambda"], "clip_param": settings["clip_range"],
            "vf_clip_param": 1e6, "entropy_coeff": settings["ent_coef"],
            "grad_clip": settings.get("max_grad_norm", SB3_MAX_GRAD_NORM),
            "grad_clip_by": "global_norm"}


def ppo_model(settings: dict) -> dict:
    """RLlib's model config: the hidden layers of ``policy_kwargs["net_arch"]``."""
    return {"fcnet_hiddens": list(settings["policy_kwargs"]["net_arch"]),
            "fcnet_activation": "tanh", "vf_share_layers": False, "free_log_std": True}


def ppo_log_std_init(settings: dict) -> float:
    """The initial log std of the Gaussian policy (``policy_kwargs["log_std_init"]``)."""
    return float(settings["policy_kwargs"].get("log_std_init", SB3_LOG_STD_INIT))
