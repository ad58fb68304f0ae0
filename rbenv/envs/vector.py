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
* **the done bookkeeping** of those modes, cleared by a reset for its rows;
* **reset masks**: ``reset(options={"reset_mask": mask})`` checked in Gymnasium's order and
  with its exception types, whatever the backend's array type;
* **the info**: every key with its ``_key`` mask (:meth:`VectorContract._info_of`); a partial
  reset's info holds the reset rows alone (zero elsewhere, ``_key`` the mask), as
  ``SyncVectorEnv``; SAME_STEP's ``final_obs`` and ``final_info`` (every key of the ending
  step's info, zero where a row did not end), masked by ``_final_obs`` and ``_final_info``.

A backend supplies the array operations, each a short method: how it takes actions and reset
masks, selects and zeroes rows (:meth:`_where`, :meth:`_keep`), owns an info value
(:meth:`_owner`), steps the transition (:meth:`_advance`), restarts rows (:meth:`_restart`)
and lays out the final observations (:meth:`_final_obs`). A new env-level behaviour written
here reaches both backends; a new backend writes those methods.
"""

from __future__ import annotations

from typing import ClassVar

import gymnasium as gym
from gymnasium.vector import AutoresetMode, VectorEnv

from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError
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
    """Seeding, reset masks, info masks, final observations and autoreset for a vector env over
    any array backend (see the module doc). Subclasses set ``backend`` (a key of
    ``rbenv.envs.options.BACKENDS``), ``mask_kind`` (the reset masks they take, for messages)
    and the array methods below; ``_seeds``, ``_episodes``, ``_done`` and ``_mask`` (all True,
    the masks of a full info) are theirs, in their arrays."""

    backend: ClassVar[str]
    mask_kind: ClassVar[str] = "a bool array"

    # ------------------------------------------------------------------- reset

    def reset(self, *, seed=None, options=None):
        """Reset all sub-envs, or those of ``options["reset_mask"]`` (an (N,) bool array of the
        backend). seed: an int (sub-env i gets s + i), a list of N ints, or None. The info of a
        partial reset holds the reset rows alone: zero elsewhere, ``_key`` the mask."""
        self._sync()
        options = dict(options or {})
        mask, full = self._reset_mask(options.pop("reset_mask", None))
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
        obs, values = self._reset_rows(mask, options)
        self._done = self._where(mask, False, self._done)
        return obs, self._info_of(values, None if full else mask)

    def _reset_mask(self, mask) -> tuple:
        """``options["reset_mask"]`` checked in Gymnasium's order and with its exception types
        (``SyncVectorEnv.reset``): not an array the backend takes or not bool -> TypeError;
        wrong shape or all False -> ValueError. Returns (the mask as the backend's array,
        whether it holds every row); None: every row."""
        if mask is None:
            return self._mask, True
        rule = f"options['reset_mask'] must be {self.mask_kind} of shape ({self.num_envs},)"
        array = self._mask_array(mask)
        if array is None:
            raise TypeError(f"{rule} with at least one True, got {validation.show(mask)} of "
                            f"type {type(mask).__name__}")
        if tuple(array.shape) != (self.num_envs,):
            raise InvalidParameterError(f"{rule}, got shape {tuple(array.shape)}")
        if not self._is_bool(array):
            raise TypeError(f"{rule}, got dtype {array.dtype}")
        if not self._any(array):
            raise InvalidParameterError(f"options['reset_mask'] must contain at least one True "
                                        f"(a sub-env to reset), got {array.tolist()}")
        full = self._all(array)
        if self._st is None and not full:
            raise gym.error.ResetNeeded("the first reset must reset every sub-env (no mask)")
        return array, full

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
        info = s.info if s.info is not None else self._info_of(self._step_info(s))
        self._finish(s)
        info.update(extra)
        return s.obs, s.reward, s.terminated, s.truncated, info

    # ------------------------------------------------------------------- info

    def _info_of(self, values: dict, rows=None) -> dict:
        """The info dict Gymnasium's vector envs return, from ``values`` (key -> an (N,) array
        of the backend, or a scalar for every row): each value as an array the env owns, with
        its ``_key`` mask. rows: a partial reset's mask; the other rows hold zeros and ``_key``
        is False there, as ``SyncVectorEnv`` builds it from the sub-envs it reset."""
        own = self._owner()
        mask = self._mask if rows is None else rows
        out = {}
        for key, value in values.items():
            value = own(value)
            out[key] = value if rows is None else self._keep(rows, value)
            out["_" + key] = mask
        return out

    def _final(self, done, s: Step) -> dict:
        """SAME_STEP: the ended rows' last observation and info, before the autoreset writes
        the new episodes: ``final_obs`` (laid out by the backend, :meth:`_final_obs`) and
        ``final_info`` (every key of the step's info, zero where a row did not end), each
        masked by ``done``. Nothing when no row ended (where the backend can tell without a
        host read, :meth:`_final_due`)."""
        if not self._final_due(done):
            return {}
        done = self._where(done, True, done)  # a mask of their own: the autoreset rebinds
        info = s.info if s.info is not None else self._info_of(self._step_info(s))
        final_info = {}
        for key, value in info.items():
            if not key.startswith("_"):
                final_info[key] = self._keep(done, value)
                final_info["_" + key] = done
        return {"final_obs": self._final_obs(done, s.obs), "_final_obs": done,
                "final_info": final_info, "_final_info": done}

    # ------------------------------------------------------------------- the backend's part

    def _sync(self) -> None:
        """A sync point before a reset (the torch env raises a pending divergence there)."""

    def _seed_array(self, seeds):
        """The sub-envs' seeds (ints) as the backend's array."""
        raise NotImplementedError

    def _where(self, mask, a, b):
        """Rows of ``a`` where ``mask``, else of ``b`` (a new array of ``b``'s dtype)."""
        raise NotImplementedError

    def _keep(self, mask, value):
        """A new array of ``value`` ((N,) or (N, ...)) with zero in the rows where ``mask``
        is False."""
        raise NotImplementedError

    def _any(self, mask) -> bool:
        raise NotImplementedError

    def _all(self, mask) -> bool:
        raise NotImplementedError

    def _rows(self, mask) -> list[int]:
        """The indices where ``mask`` is True, as a list (for messages)."""
        raise NotImplementedError

    def _mask_array(self, mask):
        """A reset mask as the backend's array (any dtype, any shape: the contract checks
        them), or None for a type the backend does not take as a mask."""
        raise NotImplementedError

    def _is_bool(self, array) -> bool:
        raise NotImplementedError

    def _owner(self):
        """A function that makes an info value an (N,) array the env owns (a scalar
        broadcast; an array the state holds copied: an autoreset may write it in place)."""
        raise NotImplementedError

    def _reset_rows(self, mask, options) -> tuple:
        """New episodes for the rows of ``mask`` (the state, the episode counters): the
        reset's (obs, info values of every row)."""
        raise NotImplementedError

    def _actions(self, actions):
        """The action batch, checked, as the backend's float array."""
        raise NotImplementedError

    def _advance(self, actions) -> Step:
        """The transition on every row (divergence raised or recorded); ``Step.info``: the
        info (:meth:`_info_of`) where the backend's autoreset writes into it, else None."""
        raise NotImplementedError

    def _step_info(self, s: Step) -> dict:
        """The info values of ``s`` (its state, terms and success) where ``Step.info`` is
        None."""
        raise NotImplementedError

    def _restart(self, rows, s: Step, *, ended_before: bool) -> None:
        """New episodes for ``rows`` (an (N,) bool mask, maybe all False) written into ``s``:
        the state, the first observations, zero reward terms and success there, and their
        reset info into ``s.info`` where the backend keeps it; with ``ended_before``
        (NEXT_STEP) also zero reward and flags, as the rows did not step."""
        raise NotImplementedError

    def _final_due(self, done) -> bool:
        """Whether SAME_STEP's final entries go into this step's info: some row ended."""
        return self._any(done)

    def _final_obs(self, done, obs):
        """SAME_STEP: ``info["final_obs"]``, the ended rows' last observations."""
        raise NotImplementedError

    def _finish(self, s: Step) -> None:
        """The backend's bookkeeping at the end of a step."""
