"""The vector half of the Gymnasium contract, written once for every array backend.

:class:`VectorContract` is the base of the NumPy vector env
(:class:`rbenv.envs.vector_env.AttitudeVectorEnv`) and the torch vector env
(:class:`rbenv.envs.torch_env.TorchVectorEnv`). It holds what Gymnasium asks of a vector env
and nothing of an array library:

* **seeding**: ``reset(seed=s)`` seeds sub-env i with ``s + i`` (or takes N seeds), a masked
  reset reseeds only its rows, and an unseeded first reset draws a base from ``np_random``;
* **the three autoreset modes**: NEXT_STEP (a sub-env that ended restarts on the following
  step: its action is ignored, its reward, flags and reward terms are zero and it returns its
  new episode's first observation), SAME_STEP (the ending step returns the new episode's first
  observation, the last one in ``info["final_obs"]``), DISABLED (a step after an end raises
  until ``reset(options={"reset_mask": mask})`` restarts those rows);
* **the done bookkeeping** of those modes, cleared by a reset for its rows.

A backend supplies the array operations, each a short method: how it checks actions and reset
masks, steps the transition (:meth:`_advance`), restarts rows (:meth:`_restart`), lays out the
final observation and info (:meth:`_final`), and builds the step's info (:meth:`_finish`). A
new env-level behaviour written here reaches both backends; a new backend writes those methods.
"""

from __future__ import annotations

from typing import ClassVar

import gymnasium as gym
from gymnasium.vector import AutoresetMode, VectorEnv

from rbenv.envs.adapter import TaskAdapter, seed_list


class Step:
    """One vector step's results, rebound by the autoreset as it restarts rows: the new state,
    the observation batch, reward, Gymnasium's flags, the reward terms, success, and the info
    (a dict, or None where the backend builds it after the autoreset)."""

    __slots__ = ("info", "obs", "reward", "st", "success", "terminated", "terms", "truncated")

    def __init__(self, st, obs, reward, terminated, truncated, terms, success, info=None):
        self.st, self.obs, self.reward = st, obs, reward
        self.terminated, self.truncated = terminated, truncated
        self.terms, self.success, self.info = terms, success, info


class VectorContract(TaskAdapter, VectorEnv):
    """Seeding, reset masks and autoreset for a vector env over any array backend (see the
    module doc). Subclasses set ``backend`` (a key of ``rbenv.envs.options.BACKENDS``) and the
    array methods below; ``_seeds``, ``_episodes`` and ``_done`` are theirs, in their arrays."""

    backend: ClassVar[str]

    # ------------------------------------------------------------------- reset

    def reset(self, *, seed=None, options=None):
        """Reset all sub-envs, or those of ``options["reset_mask"]`` (an (N,) bool array of the
        backend). seed: an int (sub-env i gets s + i), a list of N ints, or None."""
        self._sync()
        options = dict(options or {})
        mask = self._reset_mask(options.pop("reset_mask", None))
        seeds = seed_list(seed, self.num_envs)
        seeds = None if seeds is None else self._seed_array(seeds)
        VectorEnv.reset(self, seed=None if seeds is None else int(seeds[0]))
        if seeds is not None:
            self._seeds = seeds if self._seeds is None else self._where(mask, seeds,
                                                                        self._seeds)
            self._episodes = self._where(mask, 0, self._episodes)
        elif self._seeds is None:
            self._seeds = self._seed_array(range(base := int(self.np_random.integers(2**62)),
                                                 base + self.num_envs))
        obs, info = self._reset_rows(mask, options)
        self._done = self._where(mask, False, self._done)
        return obs, info

    # ------------------------------------------------------------------- step

    def step(self, actions):
        """Step all sub-envs; the autoreset mode decides which rows restart, and when."""
        if self._st is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        a = self._actions(actions)
        mode = self.autoreset_mode
        if mode is AutoresetMode.DISABLED and self._any(self._done):
            raise gym.error.ResetNeeded(
                f"sub-envs {self._rows(self._done)} have ended; with autoreset_mode DISABLED "
                "reset them with reset(options={'reset_mask': mask}) before the next step")
        s = self._advance(a)
        extra = {}
        if mode is AutoresetMode.NEXT_STEP:  # the rows that ended last step start again
            self._restart(self._done, s, ended_before=True)
            self._done = s.terminated | s.truncated
        elif mode is AutoresetMode.SAME_STEP:  # the rows that end now start again
            done = s.terminated | s.truncated
            extra = self._final(done, s)
            self._restart(done, s, ended_before=False)
        else:
            self._done = s.terminated | s.truncated
        self._st = s.st
        info = self._finish(s)
        info.update(extra)
        return s.obs, s.reward, s.terminated, s.truncated, info

    # ------------------------------------------------------------------- the backend's part

    def _sync(self) -> None:
        """A sync point before a reset (the torch env raises a pending divergence there)."""

    def _seed_array(self, seeds):
        """The sub-envs' seeds (ints) as the backend's array."""
        raise NotImplementedError

    def _where(self, mask, a, b):
        """Rows of ``a`` where ``mask``, else of ``b`` (a new array of ``b``'s dtype)."""
        raise NotImplementedError

    def _any(self, mask) -> bool:
        raise NotImplementedError

    def _rows(self, mask) -> list[int]:
        """The indices where ``mask`` is True, as a list (for messages)."""
        raise NotImplementedError

    def _reset_mask(self, mask):
        """The checked (N,) bool mask of a reset (all True for None)."""
        raise NotImplementedError

    def _reset_rows(self, mask, options) -> tuple:
        """New episodes for the rows of ``mask`` (the state, the episode counters): the
        reset's (obs, info)."""
        raise NotImplementedError

    def _actions(self, actions):
        """The action batch, checked, as the backend's float array."""
        raise NotImplementedError

    def _advance(self, actions) -> Step:
        """The transition on every row (divergence raised or recorded)."""
        raise NotImplementedError

    def _restart(self, rows, s: Step, *, ended_before: bool) -> None:
        """New episodes for ``rows`` (an (N,) bool mask, maybe all False) written into ``s``:
        the state, the first observations, zero reward terms and success there; with
        ``ended_before`` (NEXT_STEP) also zero reward and flags, as the rows did not step."""
        raise NotImplementedError

    def _final(self, done, s: Step) -> dict:
        """SAME_STEP: the info entries that hold the ended rows' last observation and info."""
        raise NotImplementedError

    def _finish(self, s: Step) -> dict:
        """The step's info dict (every key with its ``_key`` mask)."""
        raise NotImplementedError
