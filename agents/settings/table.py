"""One training entry per env id: :class:`TrainingSettings`, and the table that holds them.

The env package (:mod:`rbenv.envs.registry`) says what an id *is*; this table says how it is
trained and what it is compared with, keyed by the same id, as MuJoCo Playground keeps its
``config/*_params.py`` apart from its envs. ``rbenv train``, the learning suite, the evaluation
report's baselines and RL Zoo's files (``rbenv.agents.zoo.<algo>``) read it.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping
from dataclasses import dataclass, field

from rbenv.core.errors import InvalidParameterError

__all__ = ["TrainingSettings", "entries", "get", "register", "unregister", "zoo_hyperparams"]

# The rbenv train fields a training entry may default per algorithm (run_defaults).
RUN_DEFAULT_KEYS = ("stop_success", "eval_every", "eval_episodes", "keep_best")
_REF = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$")


@dataclass(frozen=True)
class TrainingSettings:
    """How ``env_id`` is trained and evaluated.

    baselines: scripted policy name → ``"module:Class"`` or a class with ``from_env(env)``
    whose instances have SB3's ``predict(obs, state)``; ``rbenv train`` compares every policy
    with them. hyperparams: algorithm → settings in RL Zoo's format, shared by the ids
    (:mod:`rbenv.agents.settings.tuned`; "ppo", the default algorithm, is required).
    id_settings: algorithm → this id's own settings over the shared ones (its measured
    ``n_timesteps``, say); :meth:`settings` merges them. budget: algorithm → the learning
    suite's training timesteps, where they differ from the settings' ``n_timesteps``.
    scene_budgets: (algorithm, scene) → timesteps, where a scene needs more.
    scene_env_kwargs: (algorithm, scene) → env options that training adds on that scene (a
    reward weight the scene needs); the env's own defaults stay as they are.
    engine_settings: (engine, algorithm) → settings over the id's when ``rbenv train`` runs
    that engine (``--engine sbx``'s many-env recipe, which SB3's learner did not learn with).
    scene_settings: (algorithm, scene) → settings over the id's on that scene (the id's own
    are measured on the default scene; a scene keeps the values measured on it).
    run_defaults: algorithm → ``rbenv train``'s defaults for how a run of this id is watched
    and ended, where the flags are not given (:data:`RUN_DEFAULT_KEYS`: stop at a validation
    success rate, evaluate every so many steps on so many episodes, keep the best policy).
    They are not model settings: RL Zoo never sees them.
    torchrl: ``rbenv train --engine torchrl``'s learner on this id (TorchRL's PPO, whose
    fields are not RL Zoo's: :class:`rbenv.agents.training.config.TorchRLConfig`), where it
    differs from the learner's defaults, and ``timesteps``, its budget.
    """

    env_id: str
    baselines: Mapping[str, object]
    hyperparams: Mapping[str, dict]
    budget: Mapping[str, int] = field(default_factory=dict)
    id_settings: Mapping[str, dict] = field(default_factory=dict)
    scene_budgets: Mapping[tuple, int] = field(default_factory=dict)
    scene_env_kwargs: Mapping[tuple, dict] = field(default_factory=dict)
    engine_settings: Mapping[tuple, dict] = field(default_factory=dict)
    scene_settings: Mapping[tuple, dict] = field(default_factory=dict)
    run_defaults: Mapping[str, dict] = field(default_factory=dict)
    torchrl: Mapping[str, object] = field(default_factory=dict)

    def settings(self, algo: str, engine: str = "sb3", scene: str | None = None) -> dict:
        """``algo``'s settings on this id, RL Zoo's format: the shared ``hyperparams[algo]``
        with ``id_settings[algo]`` over them, ``scene_settings[algo, scene]`` over those, and
        ``engine_settings[engine, algo]`` over all (a deep copy)."""
        return copy.deepcopy({**self.hyperparams[algo], **self.id_settings.get(algo, {}),
                              **self.scene_settings.get((algo, scene), {}),
                              **self.engine_settings.get((engine, algo), {})})

    def timesteps(self, algo: str, scene: str | None = None) -> int:
        """The suite's training budget of ``algo`` (on ``scene``, where it needs more): the
        scene's, else ``budget``'s, else the settings' ``n_timesteps``."""
        if (algo, scene) in self.scene_budgets:
            return self.scene_budgets[algo, scene]
        return self.budget.get(algo) or self.settings(algo, scene=scene)["n_timesteps"]

    def training_env_kwargs(self, algo: str, scene: str | None = None) -> dict:
        """Env options that training ``algo`` on ``scene`` adds (a deep copy; {}: none)."""
        return copy.deepcopy(dict(self.scene_env_kwargs.get((algo, scene), {})))


_ENTRIES: dict[str, TrainingSettings] = {}


def _check(entry: TrainingSettings) -> None:
    """Refuse an incomplete entry, naming what is missing."""
    if not isinstance(entry, TrainingSettings):
        raise InvalidParameterError(f"register takes a TrainingSettings, got "
                                    f"{type(entry).__name__} {entry!r}")
    where = f"training settings of {entry.env_id!r}"
    if not isinstance(entry.baselines, Mapping) or not entry.baselines:
        raise InvalidParameterError(
            f"{where}: baselines must name at least one scripted policy (name -> "
            f"'module:Class'), got {entry.baselines!r}; `rbenv train` compares every policy "
            "with them")
    for name, ref in entry.baselines.items():
        if not (isinstance(ref, str) and _REF.match(ref)) and not hasattr(ref, "from_env"):
            raise InvalidParameterError(
                f"{where}: baselines[{name!r}] must be 'module:Class' or a class with "
                f"from_env(env), got {ref!r}")
    if not isinstance(entry.hyperparams, Mapping) or "ppo" not in entry.hyperparams:
        raise InvalidParameterError(
            f"{where}: hyperparams has no settings for 'ppo' (the default algorithm), got "
            f"{entry.hyperparams!r}")
    for name, table in (("budget", entry.budget), ("id_settings", entry.id_settings)):
        if not isinstance(table, Mapping):
            raise InvalidParameterError(f"{where}: {name} must be a dict keyed by algorithm, "
                                        f"got {table!r}")
    for key, kwargs in entry.scene_env_kwargs.items():
        if not (isinstance(key, tuple) and len(key) == 2 and isinstance(kwargs, Mapping)):
            raise InvalidParameterError(
                f"{where}: scene_env_kwargs must map (algorithm, scene) to a dict of env "
                f"options, got {key!r}: {kwargs!r}")
    for algo, defaults in entry.run_defaults.items():
        if not (algo in entry.hyperparams and isinstance(defaults, Mapping)
                and set(defaults) <= set(RUN_DEFAULT_KEYS)):
            raise InvalidParameterError(
                f"{where}: run_defaults must map an algorithm with hyperparams to a dict of "
                f"{', '.join(RUN_DEFAULT_KEYS)}, got {algo!r}: {defaults!r}")
    steps = entry.torchrl.get("timesteps", 1) if isinstance(entry.torchrl, Mapping) else None
    if isinstance(steps, bool) or not isinstance(steps, int) or steps <= 0:
        raise InvalidParameterError(
            f"{where}: torchrl must be a dict of TorchRL learner fields whose 'timesteps' (if "
            f"given) is a positive int, got {entry.torchrl!r}")
    _check_pairs(where, "scene_settings", entry.scene_settings, ("algorithm", "scene"),
                 entry.hyperparams)
    _check_pairs(where, "engine_settings", entry.engine_settings, ("engine", "algorithm"),
                 entry.hyperparams)
    for key, over in entry.engine_settings.items():
        if "n_timesteps" in over:
            budgets_over = over["n_timesteps"]
            if isinstance(budgets_over, bool) or not isinstance(budgets_over, int) \
                    or budgets_over <= 0:
                raise InvalidParameterError(
                    f"{where}: engine_settings[{key!r}]['n_timesteps'] must be a positive int "
                    f"of timesteps, got {budgets_over!r}")
    budgets = {f"budget[{a!r}]": n for a, n in entry.budget.items()}
    budgets.update({f"scene_budgets[{key!r}]": n for key, n in entry.scene_budgets.items()})
    algos = dict.fromkeys([*entry.hyperparams, *entry.id_settings, *entry.budget,
                           *(algo for algo, _ in entry.scene_budgets)])
    for algo in algos:
        if not isinstance(entry.hyperparams.get(algo), Mapping):
            raise InvalidParameterError(
                f"{where}: hyperparams[{algo!r}] must be a dict of settings (RL Zoo format), "
                f"got {entry.hyperparams.get(algo)!r}; every algorithm with a budget or "
                "id_settings needs one")
        if not isinstance(entry.id_settings.get(algo, {}), Mapping):
            raise InvalidParameterError(f"{where}: id_settings[{algo!r}] must be a dict of "
                                        f"settings, got {entry.id_settings[algo]!r}")
        if algo not in entry.budget:
            budgets[f"the n_timesteps of {algo!r}'s settings"] = \
                entry.settings(algo).get("n_timesteps")
    for name, steps in budgets.items():
        if isinstance(steps, bool) or not isinstance(steps, int) or steps <= 0:
            raise InvalidParameterError(
                f"{where}: {name} must be a positive int of timesteps, got {steps!r}")


def _check_pairs(where: str, name: str, table: Mapping, words: tuple, hyperparams) -> None:
    """Each key of ``table`` a pair (``words``) whose "algorithm" has hyperparams, each value
    a dict of settings; else a named error."""
    at = words.index("algorithm")
    for key, over in table.items():
        if not (isinstance(key, tuple) and len(key) == 2 and isinstance(over, Mapping)
                and key[at] in hyperparams):
            raise InvalidParameterError(
                f"{where}: {name} must map ({', '.join(words)}) to a dict of settings, for an "
                f"algorithm with hyperparams, got {key!r}: {over!r}")


def register(entry: TrainingSettings) -> TrainingSettings:
    """Check ``entry`` (a missing baseline, budget or hyperparameter set is named here, never
    after training) and keep it; the same id again replaces its entry."""
    _check(entry)
    _ENTRIES[entry.env_id] = entry
    return entry


def unregister(env_id: str) -> None:
    """Remove ``env_id``'s entry (a test's task, say); an unknown id is ignored."""
    _ENTRIES.pop(env_id, None)


def get(env_id: str) -> TrainingSettings:
    """``env_id``'s entry; the error says what to add, and where."""
    try:
        return _ENTRIES[env_id]
    except (KeyError, TypeError):
        raise InvalidParameterError(
            f"env_id {env_id!r} has no training settings (scripted baselines, "
            "hyperparameters, budgets), which rbenv train, the suite and the report need. Add "
            f"them with rbenv.agents.settings.register(TrainingSettings(env_id={env_id!r}, "
            "baselines={'name': 'module:Class'}, hyperparams={'ppo': settings})) in the module "
            "that registers the task (a shipped task: agents/settings/shipped.py); ids with "
            f"settings: {sorted(_ENTRIES)}") from None


def entries() -> tuple:
    """Every entry, in registration order."""
    return tuple(_ENTRIES.values())


def zoo_hyperparams(algo: str) -> dict:
    """RL Zoo's table for ``algo``: env id → settings, for every entry that has them."""
    return {e.env_id: e.settings(algo) for e in _ENTRIES.values() if algo in e.hyperparams}
