"""A trained RLlib RLModule behind the same ``predict()`` as every policy: :class:`RLlibPolicy`.

Also where an RLlib run folder keeps its module (:func:`module_dir`) and its newest complete
checkpoint (:func:`latest`). RLlib's checkpoint format pickles (``class_and_ctor_args.pkl``, the
module state), so loading runs code from the folder: it is refused unless ``trust_pickle=True``
(``rbenv evaluate --trust-pickle``). Ray and torch (the ray extra) are imported only to load.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rbenv.agents.policies.runfolder import (
    CHECKPOINTS,
    CONFIG,
    LATEST,
    POLICY_DIR,
    RunFolderError,
    TrainedOn,
    confined,
    read_config,
    read_json,
    require_trust,
)

MODULE_PATH = Path("learner_group") / "learner" / "rl_module" / "default_policy"
RLLIB_HINT = ("Every RLlib run folder holds RLlib's pickles: pass the flag for runs you or your "
              "own cluster wrote")


class RLlibPolicy(TrainedOn):
    """A trained RLlib RLModule behind SB3's ``predict`` interface.

    ``path``: a run folder (its final ``policy/``, else its latest checkpoint), a checkpoint
    folder ``ckpt_<N>``, or an RLModule folder. Observations are the raw env ones (the run
    adds no observation filter); deterministic actions are the Gaussian's mean, clipped.
    """

    def __init__(self, path, *, trust_pickle: bool = False):
        path = Path(path)
        source = module_dir(path)
        require_trust(source, "an RLlib checkpoint (RLlib pickles its modules)", trust_pickle,
                      RLLIB_HINT)
        from ray.rllib.core.rl_module.rl_module import RLModule  # the ray extra

        module = RLModule.from_checkpoint(source)
        module.eval()
        config = read_config(path) if (path / CONFIG).is_file() else None
        self._bind(module, source, config)

    @classmethod
    def live(cls, algo, config: dict | None = None) -> RLlibPolicy:
        """The current module of a training RLlib ``Algorithm`` (periodic evaluation)."""
        policy = cls.__new__(cls)
        policy._bind(algo.get_module(), "live", config)
        return policy

    def _bind(self, module, source, config: dict | None) -> None:
        import torch  # the ray extra installs it

        self.module, self.source, self.config, self._torch = module, source, config, torch
        self._dist = module.get_inference_action_dist_cls()
        self.low, self.high = module.action_space.low, module.action_space.high

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        torch = self._torch
        obs = np.asarray(observation, np.float32)
        single = obs.ndim == 1
        batch = torch.from_numpy(obs[None] if single else obs)
        with torch.no_grad():
            out = self.module.forward_inference({"obs": batch})
            dist = self._dist.from_logits(out["action_dist_inputs"])
            action = (dist.to_deterministic() if deterministic else dist).sample().numpy()
        action = np.clip(action, self.low, self.high)
        return (action[0] if single else action), state


def module_dir(path: Path) -> Path:
    """The RLModule folder of a run folder, a checkpoint folder or a module folder."""
    path = Path(path)
    if (path / CONFIG).is_file():  # a run folder
        if (path / POLICY_DIR).is_dir():
            return path / POLICY_DIR
        ckpt = latest(path / CHECKPOINTS)
        if ckpt is None:
            raise RunFolderError(f"run folder {str(path)!r} has no {POLICY_DIR}/ and no "
                                 "checkpoint yet")
        return ckpt[1] / MODULE_PATH
    if (path / MODULE_PATH).is_dir():
        return path / MODULE_PATH
    if (path / "module_state.pkl").is_file() or (path / "metadata.json").is_file():
        return path
    raise RunFolderError(f"{str(path)!r} is not an RLlib run folder, checkpoint or module")


def latest(directory: Path) -> tuple[int, Path, float] | None:
    """``(steps, folder, wall_time_s)`` of the newest complete checkpoint, or None.

    latest.json's record first; if it is unusable, the highest ``ckpt_<N>`` on disk.
    """
    directory = Path(directory)
    try:
        info = read_json(directory / LATEST, "checkpoint pointer")
        folder = confined(directory, info.get("checkpoint"), "checkpoint")
        if (folder / "rllib_checkpoint.json").is_file():
            return int(info["timesteps"]), folder, float(info.get("wall_time_s") or 0.0)
    except (RunFolderError, KeyError, TypeError, ValueError):
        pass
    found = sorted((int(p.name.split("_")[1]), p) for p in directory.glob("ckpt_*")
                   if p.name.split("_")[1].isdigit() and (p / "rllib_checkpoint.json").is_file())
    return (found[-1][0], found[-1][1], 0.0) if found else None
