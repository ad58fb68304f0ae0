"""What a training run is defined by: :class:`RunConfig`, every back end's fields, and one
subclass per run folder kind: :class:`TrainConfig` (sb3 and sbx, whose run folders are the
same), :class:`rbenv.agents.training.rllib.RLlibConfig` (rllib) and :class:`TorchRLRunConfig`
(torchrl); :class:`SessionOptions`, how one session runs, for every engine.

Each config's ``resolve`` fills what the caller left unset from the task's recipe
(:func:`shipped_settings`, RL Zoo's format) and checks it; :func:`torchrl_fields` is the one
translation of a recipe to TorchRL's learner (:class:`TorchRLConfig`). The resolved config is
saved as the run folder's ``config.json`` and read back by :func:`resumed_config`. Nothing
here imports SB3, torch or Ray.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar, Literal, TypeVar, get_args

from rbenv.agents import settings
from rbenv.agents.policies import runfolder
from rbenv.agents.policies.envcheck import check_env_options
from rbenv.agents.policies.runfolder import RunFolderError
from rbenv.agents.policies.sb3 import POLICY_ACTIONS, PolicyAction
from rbenv.agents.policies.weights import ALGOS, Algo
from rbenv.agents.settings import tuned
from rbenv.agents.settings.table import RUN
from rbenv.core import validation
from rbenv.core.errors import InvalidParameterError

import rbenv

C = TypeVar("C", bound="RunConfig")
# The periodic evaluation where neither the caller nor the task's run defaults set it.
GENERIC_EVAL_EVERY, GENERIC_EVAL_EPISODES = 200_000, 100


Engine = Literal["sb3", "sbx", "rllib", "torchrl"]


@dataclass
class RunConfig:
    """The fields every back end shares; saved in ``config.json`` with the back end's own.

    Each field's docstring is its ``rbenv train`` help (:mod:`rbenv.agents.training.flags`).
    """

    # The fields a resumed run takes from the caller (when given); the rest are the run's own.
    RESUME_OVERRIDES: ClassVar[tuple[str, ...]] = ("timesteps", "threads")
    # What a config.json written before a field existed meant by its absence, or by null where
    # null now means "the task's default".
    # A run saved before policy_action acted by the auto rule.
    LEGACY_DEFAULTS: ClassVar[dict] = {"policy_action": "auto"}

    engine: Engine = "sb3"
    """The training back end: sb3 (Stable-Baselines3), sbx (SAC and TD3 in JAX with SBX, the
    same run folders as sb3; the sbx extra), rllib (PPO on Ray RLlib; the ray extra), or
    torchrl (TorchRL's PPO on the torch env, env and learner on --device; the ecosystem extra;
    its policy is saved as an SB3 PPO policy)."""
    algo: Algo = "ppo"
    """The algorithm. Its settings (hyperparameters, envs, budget, env options) come from the
    task's training settings (rbenv.agents.settings), which rl_zoo3 reads too."""
    timesteps: int | None = None
    """Environment steps to train; unset: the algorithm's shipped n_timesteps for the task. With
    --resume, a new total."""
    seed: int = 0
    """Seed of the model and the training envs."""
    scene: str | None = None
    """The spacecraft: a shipped scene's name or a scene TOML file; unset: the task's own
    default, the scene gym.make(env_id) uses (cubesat-12u; Desaturate's cubesat-6u-rw)."""
    env_id: str = rbenv.ENV_ID
    """The task: a registered id (rbenv.envs.registry), e.g. rbenv/SatelliteDetumble-v1."""
    out: str | None = None
    """The run folder (unset: ./runs/ALGO-SCENE-seedS); it must be empty or new unless --resume
    or --force."""
    env_kwargs: dict = field(default_factory=dict)
    """gym.make options as a JSON object, over the shipped ones, e.g. '{"action_mode":
    "torque"}'."""
    hyperparams: dict = field(default_factory=dict)
    """Algorithm hyperparameters as a JSON object, over the shipped ones, e.g. '{"n_steps":
    128}'."""
    checkpoint_every: int = 200_000
    """Timesteps between checkpoints."""
    eval_every: int | None = None
    """Timesteps between the periodic evaluations of the training curve; unset: the task's
    run default for the algorithm (rbenv.agents.settings), else 200000."""
    eval_episodes: int | None = None
    """Episodes of each periodic evaluation (at most 50 run side by side); unset: the task's
    run default for the algorithm, else 100."""
    report_episodes: int = 500
    """Episodes of the final report's evaluation, the same for the policy and the baselines."""
    report_seed: int = 1_000_000
    """Seed of the report's first episode (episode i is seeded report_seed + i)."""
    report_mpc: bool = False
    """Evaluate the MPC beside the policy in the report (reorientation; the mpc extra; minutes
    for 500 episodes). Without it the report shows the MPC's recorded results where its
    episodes are the recorded ones (rbenv.agents.policies.recorded)."""
    policy_action: PolicyAction | None = None
    """How the trained policy (SB3, SBX or TorchRL; RLlib's acts by its own module) acts
    wherever it is evaluated without an explicit action (the periodic evaluations, the report,
    rbenv evaluate and rbenv export): mean_throttle
    E[clip(mu + sigma eps, low, high)], mode (the Gaussian's mean, clipped by the env), auto
    (mean_throttle for PPO/A2C in throttle mode on a scene with thrusters, else mode); saved
    in config.json. Unset: the task's run default for the algorithm, else auto."""
    threads: int | None = None
    """Torch intra-op threads; unset: 1 (fastest for these small networks, and robust to other
    busy processes), or with --resume the run's own. Part of what makes a run repeatable."""
    recipe_env_kwargs: bool = True
    """Add the env options of the task's recipe for this algorithm, engine and scene (a reward
    weight a scene needs, InnoCube's action mode; rbenv.agents.settings) under --env-kwargs;
    false: the env's own defaults and --env-kwargs alone."""

    def __post_init__(self):
        if self.scene is None:
            self.scene = settings.table.default_scene(self.env_id)

    def default_out(self) -> str:
        """The run folder when ``out`` is not given."""
        return f"runs/{self.algo}-{self.scene}-seed{self.seed}"

    def check_counts(self, names, minimum: int = 1) -> None:
        """Each named field an integer >= ``minimum`` (stored as int); else a named error."""
        for name in names:
            setattr(self, name, check_count(name, getattr(self, name), minimum))

    def check_dicts(self, names) -> None:
        """Each named field a dict (a JSON object); else a named error."""
        for name in names:
            if not isinstance(getattr(self, name), dict):
                raise InvalidParameterError(f"{name} must be a dict (a JSON object), got "
                                            f"{getattr(self, name)!r}")

    def resolve(self: C) -> C:
        """Fill the defaults that depend on other fields and validate; back ends extend it."""
        baselines = task_entry(self.env_id).baselines  # a named error for an unknown id
        if self.threads is None:
            self.threads = 1
        self.policy_action = validation.choice(
            "policy_action", "auto" if self.policy_action is None else self.policy_action,
            POLICY_ACTIONS)
        self.eval_every = GENERIC_EVAL_EVERY if self.eval_every is None else self.eval_every
        self.eval_episodes = GENERIC_EVAL_EPISODES if self.eval_episodes is None \
            else self.eval_episodes
        self.check_counts(("timesteps", "checkpoint_every", "eval_every", "eval_episodes",
                           "report_episodes", "threads"))
        self.check_dicts(("env_kwargs", "hyperparams"))
        if self.report_mpc and "mpc" not in baselines:
            raise InvalidParameterError(
                f"report_mpc=True needs a task with an MPC baseline (reorientation); "
                f"{self.env_id} has {sorted(baselines)}")
        self.out = self.out or self.default_out()
        return self

    def apply_recipe_env_kwargs(self, recipe: dict) -> None:
        """``env_kwargs`` over the recipe's env options (when :attr:`recipe_env_kwargs`): the
        one place every engine takes them from."""
        if self.recipe_env_kwargs:
            self.env_kwargs = {**recipe.get("env_kwargs", {}), **self.env_kwargs}

    @classmethod
    def upgrade(cls, saved: dict) -> dict:
        """A saved ``config.json`` (a dict) in this version's form: a back end whose saved
        names changed translates the older ones here. As saved, by default."""
        return saved

    def check_env(self) -> None:
        """Make the run's env once (one satellite) and close it, so that a wrong scene, env
        option or value is named before the run folder is written. Call after :meth:`resolve`.
        """
        if "scene" in self.env_kwargs:
            raise InvalidParameterError(
                f"env_kwargs must not hold 'scene' (got {self.env_kwargs['scene']!r}): the run's "
                "scene is its own field, --scene")
        check_env_options(self.env_id, {"scene": self.scene, **self.env_kwargs})


def check_count(name: str, value, minimum: int = 1) -> int:
    """``value`` (the field ``name``) as an int, if it is an integer >= ``minimum``; else a
    named error."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise InvalidParameterError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def resumed_config(cls: type[C], out: Path, overrides: dict | None = None,
                   engine: str | None = None) -> C:
    """The saved configuration of the run in ``out``, for that folder, with ``overrides`` (the
    fields of ``cls.RESUME_OVERRIDES`` a caller gave, e.g. a new total of timesteps; None
    values are ignored). ``engine``: the engine that resumes it (None: ``cls``'s default).

    Raises :class:`RunFolderError` if the folder was trained by another back end or its
    config.json does not make a valid ``cls`` (an unknown scene, env option or value among
    them: the message names config.json and the field).
    """
    out = Path(out)
    saved = runfolder.read_config(out)
    engine = engine or cls.__dataclass_fields__["engine"].default
    if saved.get("engine", "sb3") != engine:
        raise RunFolderError(f"run folder {str(out)!r} was not trained with --engine {engine} "
                             f"(its config.json has engine {saved.get('engine', 'sb3')!r})")
    known = cls.__dataclass_fields__
    try:
        saved = cls.upgrade(saved)
    except (TypeError, ValueError) as e:
        raise RunFolderError(f"run configuration {str(out / runfolder.CONFIG)!r} is invalid: "
                             f"{e}") from None
    saved = {**cls.LEGACY_DEFAULTS, **{k: v for k, v in saved.items()
                                        if not (v is None and k in cls.LEGACY_DEFAULTS)}}
    try:
        cfg = cls(**{k: v for k, v in saved.items() if k in known})
    except TypeError as e:
        raise RunFolderError(f"run configuration {str(out / runfolder.CONFIG)!r} is invalid: "
                             f"{e}") from None
    cfg.out = str(out)  # the folder given, not the one recorded when the run started
    for name, value in (overrides or {}).items():
        if name not in cls.RESUME_OVERRIDES:
            raise InvalidParameterError(f"a resumed run takes only {cls.RESUME_OVERRIDES} from "
                                        f"the caller, got {name!r}")
        if value is not None:
            setattr(cfg, name, value)
    # The saved env options are the run's whole set (the recipe's of its start included): a
    # recipe changed since must not change a run's reward halfway, so resolve() does not add
    # the current recipe's under them.
    env_kwargs = cfg.env_kwargs
    try:
        cfg.resolve()  # checks env_kwargs is a dict
        cfg.env_kwargs = dict(env_kwargs)
        cfg.check_env()
    except (TypeError, ValueError) as e:
        raise RunFolderError(f"the run folder {str(out)!r} holds a configuration that cannot "
                             f"run ({str(out / runfolder.CONFIG)!r}): {e}; fix that file, or "
                             "start the run again with --force instead of --resume") from None
    return cfg


OFF_POLICY = ("sac", "td3", "tqc", "crossq")
# Keys of a recipe that are not model keyword arguments: rbenv train reads them into
# TrainConfig's own fields (rl_zoo3's ExpManager does the same; "run" is rbenv's own).
ZOO_KEYS = ("policy", "n_envs", "n_timesteps", "normalize", "env_kwargs", "monitor_kwargs",
            RUN)


def task_entry(env_id: str) -> settings.TrainingSettings:
    """The training settings of ``env_id`` (:func:`rbenv.agents.settings.get`, whose error says
    what to add, where); the goal form, which has none, gets an error that says how to train
    it."""
    if env_id == rbenv.envs.goal.GOAL_ID:
        raise InvalidParameterError(
            f"env_id {env_id!r} (the goal form, a Dict observation) is not trained by rbenv "
            "train, whose run folders, reports and suite use the registry's flat observations; "
            "train it with SB3 and rbenv.agents.training.her (its docstring has the recipe), "
            "or train rbenv/SatelliteReorient-v1, the same task")
    return settings.get(env_id)


def shipped_settings(algo: str, env_id: str = rbenv.ENV_ID, engine: str | None = None,
                     scene: str | None = None) -> dict:
    """The recipe shipped for ``algo`` on ``env_id``, trained by ``engine`` on ``scene`` (None:
    the general one), in RL Zoo's format plus ``"run"``: its training entry's
    (:meth:`rbenv.agents.settings.TrainingSettings.recipe`; the shared dicts live in
    rbenv.agents.settings.tuned).

    This is the one source of every engine's defaults; ``rl_zoo3 --conf-file
    rbenv.agents.zoo.<algo>`` reads the general recipe. Returns a deep copy.
    """
    if algo not in ALGOS:
        raise InvalidParameterError(f"algo must be one of {', '.join(ALGOS)}, got {algo!r}")
    entry = task_entry(env_id)  # the training settings: one source
    if algo not in entry.algos():
        raise InvalidParameterError(f"the training settings of {env_id!r} have no {algo} "
                                    f"recipe; they have {sorted(entry.algos())}")
    return entry.recipe(algo, engine, scene)


def normalize_kwargs(setting) -> dict | None:
    """VecNormalize keyword arguments from the zoo's ``normalize`` (bool or dict)."""
    if setting is True:
        return {"norm_obs": True, "norm_reward": True}
    if not setting:
        return None
    return dict(setting)


# VecNormalize's keyword arguments a run may set, with their rule (the engine passes gamma,
# the hyperparameters' discount, and training itself).
NORMALIZE_FLAGS = ("norm_obs", "norm_reward")
NORMALIZE_LIMITS = ("clip_obs", "clip_reward", "epsilon")


def check_normalize(value: dict | None) -> None:
    """``normalize``: None or an object of VecNormalize's options, flags true or false and
    limits numbers > 0; else an error naming the key, the value and the rule."""
    if value is None:
        return
    if not isinstance(value, dict):
        raise InvalidParameterError(f"normalize must be a JSON object, got {value!r}")
    unknown = sorted(set(value) - set(NORMALIZE_FLAGS) - set(NORMALIZE_LIMITS))
    if unknown:
        raise InvalidParameterError(
            f"normalize has unknown key(s) {unknown}; keys are "
            f"{', '.join(NORMALIZE_FLAGS + NORMALIZE_LIMITS)} (gamma is the hyperparameters')")
    for key in NORMALIZE_FLAGS:
        if key in value:
            validation.flag(f"normalize['{key}']", value[key])
    for key in NORMALIZE_LIMITS:
        if key in value:
            validation.positive(f"normalize['{key}']", value[key])


SBX_ALGOS = ("sac", "td3")


@dataclass
class TrainConfig(RunConfig):
    """A run of the SB3 back end, or of the SBX one (``engine="sbx"``: SAC or TD3 in JAX, the
    same fields and run folder; its policy files load as SB3 policies); saved as
    ``config.json`` in the run folder."""

    n_envs: int | None = None
    """Envs stepped side by side in one native vector env; unset: the shipped n_envs."""
    normalize: dict | None = None
    """VecNormalize's keyword arguments as a JSON object ({}: no normalisation); unset: the
    shipped settings'."""
    keep_best: bool | None = None
    """End on the best validated policy: the run's policy.pt becomes the weights of the periodic
    evaluation (--eval-every, plus one at the last step) with the highest success rate (then
    mean return); training.json names the step kept. Unset: the task's run default for the
    algorithm, else on for sac, td3, tqc and crossq, whose policy can collapse late in
    training, and off for ppo."""
    max_minutes: float | None = None
    """Stop training after this many minutes of training wall time (over all sessions of the
    run) and save, evaluate and report the model as at the end of --timesteps; unset: no
    limit. The console says when and why it stopped; --resume with a larger --max-minutes
    trains on."""
    stop_success: float | None = None
    """Stop training at the first periodic evaluation (--eval-every, --eval-episodes: the
    validation episodes, never the report's) whose success rate reaches this fraction, e.g.
    1.0; the run ends on the policy that evaluation measured, and training.json and the report
    say when it stopped. 0: never, train to --timesteps. Unset: the task's run default for the
    algorithm (Reorient-v1's PPO: 1.0), else never."""
    save_replay_buffer: bool = False
    """Off-policy (sac, td3, tqc, crossq): keep the replay buffer with each checkpoint
    (replay_buffer_N.npz, the latest only; most of the run folder's size), so that --resume
    continues with it. Without it --resume starts with an empty buffer: SB3 counts
    learning_starts from step 0 of the run, so it does not wait again; gradient steps go on at
    once, sampling the transitions collected since the resume."""

    RESUME_OVERRIDES: ClassVar[tuple[str, ...]] = (*RunConfig.RESUME_OVERRIDES, "max_minutes",
                                                    "stop_success")
    # Runs written before --save-replay-buffer kept their buffer: a resume goes on keeping it.
    # A run saved with stop_success null (before the run defaults) never stopped early.
    LEGACY_DEFAULTS: ClassVar[dict] = {**RunConfig.LEGACY_DEFAULTS, "save_replay_buffer": True,
                                       "stop_success": 0.0}

    def resolve(self) -> TrainConfig:
        """Fill defaults that depend on the algorithm; validate names and counts."""
        if self.engine not in ("sb3", "sbx"):
            raise InvalidParameterError(f"engine must be sb3 or sbx for TrainConfig, got "
                                        f"{self.engine!r}")
        if self.engine == "sbx" and self.algo not in SBX_ALGOS:
            raise InvalidParameterError(f"algo must be one of {', '.join(SBX_ALGOS)} for "
                                        f"--engine sbx, got {self.algo!r}")
        shipped = shipped_settings(self.algo, self.env_id, self.engine, self.scene)
        apply_run_defaults(self, shipped)
        if self.stop_success is None:
            self.stop_success = 0.0
        if self.timesteps is None:
            self.timesteps = shipped["n_timesteps"]
        if self.n_envs is None:
            self.n_envs = shipped["n_envs"]
        if self.normalize is None:
            self.normalize = normalize_kwargs(shipped.get("normalize", False))
        check_normalize(self.normalize)
        self.check_counts(("n_envs",))
        if self.keep_best is None:
            self.keep_best = self.algo in OFF_POLICY
        if self.max_minutes is not None and (
                isinstance(self.max_minutes, bool)
                or not isinstance(self.max_minutes, numbers.Real) or not self.max_minutes > 0):
            raise InvalidParameterError(f"max_minutes must be a number > 0, got "
                                        f"{self.max_minutes!r}")
        check_stop_success(self.stop_success)
        super().resolve()
        # Shipped settings first, then the caller's overrides (a resumed run's are complete).
        self.hyperparams = {**{k: v for k, v in shipped.items() if k not in ZOO_KEYS},
                            **self.hyperparams}
        # The recipe's env options (the algorithm's, then its scene's), then the caller's.
        self.apply_recipe_env_kwargs(shipped)
        starts = self.hyperparams.get("learning_starts", 0)
        if self.algo in OFF_POLICY and self.timesteps <= starts:
            raise InvalidParameterError(
                f"timesteps must exceed {self.algo}'s learning_starts ({starts}) or no gradient "
                f"step is taken, got timesteps={self.timesteps}; raise --timesteps or pass "
                "--hyperparams '{\"learning_starts\": N}'")
        return self


def check_stop_success(value) -> None:
    """``stop_success`` a success rate in [0, 1]; else a named error."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not 0 <= value <= 1:
        raise InvalidParameterError(f"stop_success must be a success rate in [0, 1] (0: never "
                                    f"stop early), got {value!r}")


def apply_run_defaults(cfg: RunConfig, recipe: dict) -> None:
    """Set each field the caller left unset (None) that the run defaults of ``recipe`` (its
    ``"run"``: :func:`shipped_settings`) name and ``cfg`` has."""
    for name, value in recipe.get(RUN, {}).items():
        if hasattr(cfg, name) and getattr(cfg, name) is None:
            setattr(cfg, name, value)


ENGINES: tuple[str, ...] = get_args(Engine)


@dataclass(frozen=True)
class SessionOptions:
    """How one training session runs, for every back end; not saved with the run (a run
    trained on one device or cluster may resume on another). Each field's docstring says which
    engines read it (:attr:`READ_BY`); ``rbenv train`` refuses a field its engine does not
    read."""

    # field -> the engines that read it (the rest ignore it).
    READ_BY: ClassVar[dict[str, tuple[str, ...]]] = {
        "progress": ENGINES, "trust_pickle": ENGINES, "tensorboard": ("sb3", "sbx"),
        "verbose": ("sb3", "sbx"), "address": ("rllib",), "device": ("torchrl",),
        "quick": ("torchrl",)}

    progress: bool = True
    """Show training progress (a bar for sb3, a line per iteration for rllib and torchrl).
    Every engine."""
    trust_pickle: bool = False
    """Let --resume unpickle a run folder written before rbenv's pickle-free format, or an RLlib
    run's checkpoints. Unpickling runs any code in the files: only for folders from a source
    you trust. Every engine."""
    tensorboard: str | None = None
    """Also log training to TensorBoard under this folder (DIR/RUN_NAME). sb3 and sbx."""
    verbose: int = 0
    """Stable-Baselines3's own logging: 0 (none), 1 or 2. sb3 and sbx."""
    address: str | None = None
    """A running Ray cluster: 'auto' (started on this machine with ray start) or HOST:PORT of
    its head; unset: a private Ray instance on 127.0.0.1. rllib."""
    device: str = "cpu"
    """The torch device of env and learner (cpu, cuda, cuda:1, ...). torchrl."""
    quick: bool = False
    """A smoke run (CI's form): 16384 timesteps unless --timesteps is given, and 50 episodes
    for the report; not with --resume. torchrl."""

    @classmethod
    def read_by(cls, engine: str) -> tuple[str, ...]:
        """The fields ``engine`` reads."""
        return tuple(name for name, engines in cls.READ_BY.items() if engine in engines)

    @classmethod
    def ignored_by(cls, engine: str) -> tuple[str, ...]:
        """The fields ``engine`` does not read."""
        return tuple(name for name in cls.READ_BY if name not in cls.read_by(engine))


# A TorchRL learner field (TorchRLConfig) → the recipe key it is read from (RL Zoo's name).
TORCHRL_NAMES = {"num_envs": "n_envs", "rollout": "n_steps", "minibatch": "batch_size",
                 "epochs": "n_epochs", "lr": "learning_rate", "gamma": "gamma",
                 "lmbda": "gae_lambda", "clip": "clip_range"}
# The keys of a TorchRL run's hyperparams (RL Zoo's names, and TorchRL's own "compile");
# policy_kwargs takes net_arch (two layers of one width) and log_std_init.
TORCHRL_HYPERPARAMS = (*TORCHRL_NAMES.values(), "policy_kwargs", "compile")
TORCHRL_POLICY_KWARGS = ("net_arch", "log_std_init")


def torchrl_fields(recipe: dict) -> dict:
    """:class:`TorchRLConfig`'s learner fields from a recipe in RL Zoo's names: the one
    translation. Reads the keys of :data:`TORCHRL_NAMES`, ``policy_kwargs``' ``net_arch`` (two
    hidden layers of one width: ``hidden``) and ``log_std_init``, ``n_timesteps``
    (``timesteps``) and ``compile``, where present; the recipe's other keys (``normalize``,
    ``ent_coef``, ...) are not the learner's and are left."""
    out = {field: recipe[key] for field, key in TORCHRL_NAMES.items() if key in recipe}
    policy = recipe.get("policy_kwargs", {})
    if "net_arch" in policy:
        arch = policy["net_arch"]
        if not (isinstance(arch, list | tuple) and len(arch) == 2 and arch[0] == arch[1]):
            raise InvalidParameterError(
                f"policy_kwargs.net_arch must be two hidden layers of one width for --engine "
                f"torchrl (its actor and critic are two tanh layers), got {arch!r}")
        out["hidden"] = arch[0]
    if "log_std_init" in policy:
        out["log_std_init"] = policy["log_std_init"]
    if "n_timesteps" in recipe:
        out["timesteps"] = recipe["n_timesteps"]
    if "compile" in recipe:
        out["compile"] = recipe["compile"]
    return out


# The learner's defaults: tuned.TORCHRL_PPO, translated.
_TORCHRL = torchrl_fields(tuned.TORCHRL_PPO)


@dataclass
class TorchRLConfig:
    """TorchRL's PPO learner (:func:`rbenv.agents.training.torchrl.train`, and a run of
    ``--engine torchrl`` through :class:`TorchRLRunConfig`); the defaults are
    :data:`rbenv.agents.settings.tuned.TORCHRL_PPO`'s, chosen for the default scene on a CPU
    (docs/torch.md). Lengths are in samples (env steps of one sub-env)."""

    env_id: str = rbenv.ENV_ID
    scene: str | None = None
    device: str = "cpu"
    timesteps: int = _TORCHRL["timesteps"]
    num_envs: int = _TORCHRL["num_envs"]
    rollout: int = _TORCHRL["rollout"]  # steps per sub-env per batch
    minibatch: int = _TORCHRL["minibatch"]
    epochs: int = _TORCHRL["epochs"]
    lr: float = _TORCHRL["lr"]
    gamma: float = _TORCHRL["gamma"]
    lmbda: float = _TORCHRL["lmbda"]
    clip: float = _TORCHRL["clip"]
    hidden: int = _TORCHRL["hidden"]
    log_std_init: float = _TORCHRL["log_std_init"]
    seed: int = 0
    threads: int = 1
    compile: bool = False
    eval_episodes: int = 500
    eval_every: int = 0  # samples between held-out evaluations during training (0: none)
    env_kwargs: dict = field(default_factory=dict)  # the torch env's options over the scene

    def check(self) -> TorchRLConfig:
        """Every learner field in its range; else an error naming the field, value and rule."""
        for name in ("num_envs", "rollout", "minibatch", "epochs", "hidden", "threads"):
            check_count(name, getattr(self, name))
        for name, rule, ok in (("lr", "> 0", lambda v: v > 0), ("clip", "> 0", lambda v: v > 0),
                               ("gamma", "in (0, 1]", lambda v: 0 < v <= 1),
                               ("lmbda", "in [0, 1]", lambda v: 0 <= v <= 1),
                               ("log_std_init", "", lambda v: True)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) \
                    or not math.isfinite(value) or not ok(value):
                raise InvalidParameterError(f"{name} must be a finite number {rule}".rstrip()
                                            + f", got {value!r}")
        if not isinstance(self.compile, bool):
            raise InvalidParameterError(f"compile must be true or false, got {self.compile!r}")
        batch = self.num_envs * self.rollout
        if isinstance(self.timesteps, bool) or not isinstance(self.timesteps, numbers.Integral) \
                or self.timesteps < batch:
            raise InvalidParameterError(
                f"timesteps must be an integer >= num_envs * rollout = {batch} (one batch), "
                f"got {self.timesteps!r}")
        return self


@dataclass
class TorchRLRunConfig(RunConfig):
    """A run of the TorchRL back end (``--engine torchrl``: TorchRL's PPO on the torch env);
    saved as ``config.json``. Its ``hyperparams`` are the learner's, in RL Zoo's names
    (:data:`TORCHRL_HYPERPARAMS`, translated by :func:`torchrl_fields`), resolved in full: the
    caller's over the task's ``Recipe("ppo", "torchrl")`` (:func:`shipped_settings`); its
    policy files are an SB3 PPO policy's. The recipe's ``env_kwargs`` are not applied (they
    were measured with SB3): the env options are the caller's."""

    engine: Engine = "torchrl"
    stop_success: float | None = None
    """Stop training at the first periodic evaluation (--eval-every, --eval-episodes) whose
    success rate reaches this fraction; 0: never. Unset: the task's run default for ppo."""

    RESUME_OVERRIDES: ClassVar[tuple[str, ...]] = (*RunConfig.RESUME_OVERRIDES, "stop_success")
    # Folders written before this engine took the recipe's env options resume without them.
    LEGACY_DEFAULTS: ClassVar[dict] = {**RunConfig.LEGACY_DEFAULTS, "recipe_env_kwargs": False}

    def default_out(self) -> str:
        return f"runs/torchrl-{self.algo}-{self.scene}-seed{self.seed}"

    @classmethod
    def upgrade(cls, saved: dict) -> dict:
        """A config.json whose hyperparams have TorchRL's names (rbenv before the recipes:
        num_envs, rollout, ..., hidden) in RL Zoo's names."""
        hp = saved.get("hyperparams")
        if not isinstance(hp, dict) or not set(hp) & {*TORCHRL_NAMES, "hidden"} - {"gamma"}:
            return saved
        new = {key: hp[field] for field, key in TORCHRL_NAMES.items() if field in hp}
        policy = {}
        if "hidden" in hp:
            policy["net_arch"] = [hp["hidden"], hp["hidden"]]
        if "log_std_init" in hp:
            policy["log_std_init"] = hp["log_std_init"]
        if policy:
            new["policy_kwargs"] = policy
        if "compile" in hp:
            new["compile"] = hp["compile"]
        unknown = sorted(set(hp) - {*TORCHRL_NAMES, "hidden", "log_std_init", "compile"})
        if unknown:
            raise InvalidParameterError(f"hyperparams: {unknown} are not --engine torchrl's "
                                        "hyperparameters")
        return {**saved, "hyperparams": new}

    def resolve(self) -> TorchRLRunConfig:
        """The task's torchrl recipe under the caller's hyperparams; the recipe's run defaults;
        every field checked."""
        if self.algo != "ppo":
            raise InvalidParameterError(f"algo must be ppo for --engine torchrl, got "
                                        f"{self.algo!r}")
        shipped = shipped_settings(self.algo, self.env_id, self.engine, self.scene)
        apply_run_defaults(self, shipped)
        if self.stop_success is None:
            self.stop_success = 0.0
        check_stop_success(self.stop_success)
        if self.timesteps is None:
            self.timesteps = shipped["n_timesteps"]
        super().resolve()
        self.apply_recipe_env_kwargs(shipped)
        unknown = sorted(set(self.hyperparams) - set(TORCHRL_HYPERPARAMS))
        policy = self.hyperparams.get("policy_kwargs", {})
        if not isinstance(policy, dict):
            raise InvalidParameterError(f"hyperparams.policy_kwargs must be a dict (JSON "
                                        f"object), got {policy!r}")
        unknown += [f"policy_kwargs.{k}" for k in sorted(set(policy) - set(TORCHRL_POLICY_KWARGS))]
        if unknown:
            raise InvalidParameterError(
                f"hyperparams: {unknown} are not --engine torchrl's hyperparameters; it takes "
                f"{', '.join(TORCHRL_HYPERPARAMS)} (policy_kwargs: "
                f"{', '.join(TORCHRL_POLICY_KWARGS)}; the budget is --timesteps)")
        shipped["compile"] = TorchRLConfig.compile
        missing = [k for k in TORCHRL_HYPERPARAMS if k not in self.hyperparams
                   and k not in shipped]
        missing += [f"policy_kwargs.{k}" for k in TORCHRL_POLICY_KWARGS
                    if k not in policy and k not in shipped.get("policy_kwargs", {})]
        if missing:
            raise InvalidParameterError(
                f"the torchrl recipe of {self.env_id} (Recipe('ppo', 'torchrl') of its training "
                f"settings, over Recipe('ppo')) has no {missing}: add them, or pass them in "
                "--hyperparams")
        shipped_policy = {k: v for k, v in shipped.get("policy_kwargs", {}).items()
                          if k in TORCHRL_POLICY_KWARGS}
        self.hyperparams = {k: self.hyperparams.get(k, shipped.get(k))
                            for k in TORCHRL_HYPERPARAMS}
        self.hyperparams["policy_kwargs"] = {**shipped_policy, **policy}
        self.learner("cpu").check()
        return self

    def learner(self, device: str) -> TorchRLConfig:
        """The learner's configuration for this run on ``device``."""
        return TorchRLConfig(env_id=self.env_id, scene=self.scene, device=device,
                             timesteps=self.timesteps, seed=self.seed, threads=self.threads,
                             env_kwargs=dict(self.env_kwargs),
                             **torchrl_fields(self.hyperparams))

    def check_env(self) -> None:
        """The NumPy env's check, then the torch env made once with the run's options."""
        super().check_env()
        import gymnasium as gym  # the torch env imports torch only when made

        gym.make_vec(self.env_id, num_envs=1, backend="torch", scene=self.scene,
                     **self.env_kwargs).close()
