"""One training entry per env id: :class:`TrainingSettings`, and the table that holds them.

The env package (:mod:`rbenv.envs.registry`) says what an id *is*; this table says how it is
trained and what it is compared with, keyed by the same id, as MuJoCo Playground keeps its
``config/*_params.py`` apart from its envs. ``rbenv train`` (every engine), the learning suite,
the evaluation report's baselines and RL Zoo's files (``rbenv.agents.zoo.<algo>``) read it.

An entry's numbers are in one table, ``recipes``: :class:`Recipe` (algorithm, engine, scene) →
a dict in RL Zoo's format. :meth:`TrainingSettings.recipe` merges them from the general to the
specific; the result is all a run of that combination needs, its budget (``n_timesteps``)
included.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping
from dataclasses import dataclass

from rbenv.core.errors import InvalidParameterError

__all__ = ["RUN", "RUN_KEYS", "Recipe", "TrainingSettings", "entries", "get", "register",
           "unregister", "zoo_hyperparams"]

# The key of a recipe that holds how ``rbenv train`` watches and ends a run (not model
# settings: RL Zoo's files drop it), and the keys it may hold.
RUN = "run"
RUN_KEYS = ("stop_success", "eval_every", "eval_episodes", "keep_best", "policy_action")
# Keys whose dicts merge key by key from the general recipe to the specific one; every other
# key of a more specific recipe replaces the general one's value whole (policy_kwargs too).
MERGED = ("env_kwargs", RUN)
_REF = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$")


@dataclass(frozen=True)
class Recipe:
    """The key of a recipe: an algorithm ("ppo", "sac", ...), and optionally the engine
    (``rbenv train --engine``: "sb3", "sbx", "rllib", "torchrl") and the scene (a shipped
    scene's name) it is for; None: any."""

    algo: str
    engine: str | None = None
    scene: str | None = None

    def __repr__(self) -> str:
        """As it is written: ``Recipe('ppo')``, ``Recipe('sac', 'sbx')``,
        ``Recipe('ppo', scene='boom-sat')``."""
        args = [repr(self.algo)] + ([repr(self.engine)] if self.engine else [])
        if self.scene:
            args.append(f"scene={self.scene!r}")
        return f"Recipe({', '.join(args)})"

    def __post_init__(self):
        for name in ("algo", "engine", "scene"):
            value = getattr(self, name)
            if not (isinstance(value, str) and value) and not (value is None and name != "algo"):
                raise InvalidParameterError(
                    f"Recipe.{name} must be a non-empty string"
                    + (" or None (any)" if name != "algo" else "") + f", got {value!r}")


@dataclass(frozen=True)
class TrainingSettings:
    """How ``env_id`` is trained and evaluated.

    baselines: scripted policy name → ``"module:Class"`` or a class with ``from_env(env)``
    whose instances have SB3's ``predict(obs, state)``; ``rbenv train`` compares every policy
    with them.

    recipes: :class:`Recipe` → a dict in RL Zoo's format; ``Recipe("ppo")`` (PPO, the default
    algorithm, on any engine and scene) is required. A recipe holds the model's
    hyperparameters and ``n_timesteps`` (the budget: of ``rbenv train``, the learning suite and
    RL Zoo alike), ``n_envs``, ``normalize``, ``env_kwargs`` (gym.make options the training
    adds: a reward weight a scene needs, say) and ``"run"`` (:data:`RUN_KEYS`: ``rbenv
    train``'s defaults for stopping at a validation success rate, evaluating every so many
    steps on so many episodes, keeping the best policy; RL Zoo never sees them). A more
    specific recipe holds only what differs: :meth:`recipe` merges
    ``(algo)`` ← ``(algo, scene)`` ← ``(algo, engine)`` ← ``(algo, engine, scene)``.
    """

    env_id: str
    baselines: Mapping[str, object]
    recipes: Mapping[Recipe, dict]

    def recipe(self, algo: str, engine: str | None = None, scene: str | None = None) -> dict:
        """``algo``'s settings on this id for ``engine`` and ``scene`` (None: the general
        ones), RL Zoo's format plus ``"run"``: the recipes of ``(algo)``, ``(algo, scene)``,
        ``(algo, engine)`` and ``(algo, engine, scene)`` merged in that order, the later over
        the earlier (``env_kwargs`` and ``"run"`` key by key). A deep copy."""
        out: dict = {}
        keys = [Recipe(algo)]
        if scene is not None:
            keys.append(Recipe(algo, scene=scene))
        if engine is not None:
            keys.append(Recipe(algo, engine))
            if scene is not None:
                keys.append(Recipe(algo, engine, scene))
        for key in keys:
            for name, value in self.recipes.get(key, {}).items():
                out[name] = {**out.get(name, {}), **value} if name in MERGED else value
        return copy.deepcopy(out)

    def algos(self) -> tuple:
        """The algorithms this id has a general recipe for."""
        return tuple(dict.fromkeys(k.algo for k in self.recipes
                                  if isinstance(k, Recipe) and k == Recipe(k.algo)))


_ENTRIES: dict[str, TrainingSettings] = {}


def _positive_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value > 0


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
    if not isinstance(entry.recipes, Mapping) or not isinstance(
            entry.recipes.get(Recipe("ppo")), Mapping):
        raise InvalidParameterError(
            f"{where}: recipes has no Recipe('ppo') (PPO's settings, the default algorithm), "
            f"got {entry.recipes!r}")
    for key, recipe in entry.recipes.items():
        if not isinstance(key, Recipe) or not isinstance(recipe, Mapping):
            raise InvalidParameterError(
                f"{where}: recipes must map Recipe(algo, engine, scene) to a dict of settings "
                f"(RL Zoo format), got {key!r}: {recipe!r}")
    general = entry.algos()
    for key, recipe in entry.recipes.items():
        at = f"{where}: recipes[{key!r}]"
        if key.algo not in general:
            raise InvalidParameterError(f"{at}: {key.algo!r} has no general recipe "
                                        f"Recipe({key.algo!r}); add one (algorithms with one: "
                                        f"{list(general)})")
        for name in MERGED:
            if not isinstance(recipe.get(name, {}), Mapping):
                raise InvalidParameterError(f"{at}[{name!r}] must be a dict, got "
                                            f"{recipe[name]!r}")
        unknown = sorted(set(recipe.get(RUN, {})) - set(RUN_KEYS))
        if unknown:
            raise InvalidParameterError(f"{at}[{RUN!r}]: {unknown} are not run defaults; it "
                                        f"takes {', '.join(RUN_KEYS)}")
        if "n_timesteps" in recipe and not _positive_int(recipe["n_timesteps"]):
            raise InvalidParameterError(f"{at}['n_timesteps'] must be a positive int of "
                                        f"timesteps, got {recipe['n_timesteps']!r}")
    for algo in general:
        steps = entry.recipes[Recipe(algo)].get("n_timesteps")
        if not _positive_int(steps):
            raise InvalidParameterError(
                f"{where}: recipes[Recipe({algo!r})]['n_timesteps'] must be a positive int of "
                f"timesteps (the budget of {algo} on this id), got {steps!r}")


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
    if not isinstance(env_id, str):
        hint = (f" (a task entry: pass its .env_id, {env_id.env_id!r})"
                if isinstance(getattr(env_id, "env_id", None), str) else "")
        raise InvalidParameterError(
            f"env_id must be a Gymnasium id string such as 'rbenv/SatelliteReorient-v2', got "
            f"{type(env_id).__name__} {env_id!r}{hint}")
    try:
        return _ENTRIES[env_id]
    except KeyError:
        raise InvalidParameterError(
            f"env_id {env_id!r} has no training settings (scripted baselines, "
            "hyperparameters, budgets), which rbenv train, the suite and the report need. Add "
            f"them with rbenv.agents.settings.register(TrainingSettings(env_id={env_id!r}, "
            "baselines={'name': 'module:Class'}, recipes={Recipe('ppo'): settings})) in the "
            "module that registers the task (a shipped task: agents/settings/shipped.py); ids "
            f"with settings: {sorted(_ENTRIES)}") from None


def entries() -> tuple:
    """Every entry, in registration order."""
    return tuple(_ENTRIES.values())


def zoo_hyperparams(algo: str) -> dict:
    """RL Zoo's table for ``algo``: env id → its recipe for the sb3 engine (the zoo trains SB3's
    models) on the scene ``gym.make(env_id)`` uses (the zoo's env, and rbenv train's without
    --scene) without ``"run"`` (rbenv train's own), for every entry that has one."""
    table = {}
    for e in _ENTRIES.values():
        if algo in e.algos():
            table[e.env_id] = e.recipe(algo, "sb3", scene=default_scene(e.env_id))
            table[e.env_id].pop(RUN, None)
    return table


def default_scene(env_id: str) -> str | None:
    """The scene ``gym.make(env_id)`` uses; None for an id the registry does not hold."""
    from rbenv.envs import registry

    try:
        return registry.get(env_id).scene
    except InvalidParameterError:
        return None
