"""One ``predict()`` for every policy, and one loader for every trained one.

:class:`Policy` is what evaluation, reports and your own code call: SB3's ``predict`` signature.
The scripted baselines (:mod:`rbenv.agents.baselines`), :class:`~.sb3.RunPolicy` (SB3 models)
and :class:`~.rllib.RLlibPolicy` all satisfy it. :func:`load_policy` opens a run folder or
model file of either engine.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol, runtime_checkable

from rbenv.agents.policies import runfolder
from rbenv.agents.policies.compiled import CPolicy, is_exported
from rbenv.agents.policies.rllib import RLlibPolicy
from rbenv.agents.policies.sb3 import RunPolicy, load_run_policy


@runtime_checkable
class Policy(Protocol):
    """Anything that maps observations (one or a batch) to actions."""

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        """``(action, state)`` for ``observation``; ``state`` is returned unchanged by
        stateless policies."""


def load_policy(path, action: str = "auto", *, trust_pickle: bool = False
                ) -> RunPolicy | RLlibPolicy | CPolicy:
    """A ready policy from a run folder (SB3 or RLlib), its ``policy.pt`` or a checkpoint.

    An SB3 model comes with its own observation statistics and the run's configuration
    (``policy.make_env()`` builds the env it was trained on; ``action`` as :class:`RunPolicy`).
    Nothing is unpickled without ``trust_pickle=True``: a pickle-based file (an older run's
    ``model.zip``/``vecnormalize.pkl``, a foreign SB3 ``.zip``, any RLlib checkpoint) raises
    :class:`~.runfolder.UntrustedPickleError`. Either policy has ``env_kwargs`` and ``env_id``.
    An exported ``policy.c`` (compiled here) or its compiled ``.so``, with the ``export.json``
    of ``rbenv export`` beside it, is flown through ctypes (:class:`~.compiled.CPolicy`).
    """
    path = Path(path)
    if is_exported(path):
        return CPolicy(path)
    if path.is_dir() and (path / runfolder.CONFIG).is_file():
        if runfolder.read_config(path).get("engine") == "rllib":
            return RLlibPolicy(path, trust_pickle=trust_pickle)
    return load_run_policy(path, action, trust_pickle=trust_pickle)
