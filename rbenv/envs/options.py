"""The env options, declared once: :class:`EnvOptions`, one field per ``gym.make`` /
``gym.make_vec`` keyword argument, with its default and its docstring.

The shells' own options are declared beside it (:class:`ShellOptions`, :class:`VectorOptions`,
:class:`BackendOptions`: numpy or torch, and the torch env's own), and :data:`OPTIONS_OF` names
the options each shell takes. Each shell has one constructor, ``(num_envs, scene,
**options)``, that hands its keywords to :func:`take`: the declared defaults filled in, an
unknown name refused as Python refuses it. Everything else derives from the declarations or
is tested against them (tests/rbenv/test_options.py): :func:`rbenv.tasks.build` and
:func:`rbenv.satellite.plant.make_plant`, the Arguments table of every env's docstring
(:func:`options_table`) and the Options table of docs/api.md.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import itertools
import textwrap
from functools import cache

from gymnasium.vector import AutoresetMode


@dataclasses.dataclass(frozen=True)
class EnvOptions:
    """The options of every rbenv env (all optional); the vector env adds ``num_envs``,
    ``max_episode_steps`` and ``autoreset_mode``, both add ``render_mode``."""

    scene: object = None
    """A shipped scene's name, a TOML path or an ``rbenv.Scene``; unset: the task's default
    scene (``cubesat-12u``; desaturation: ``cubesat-6u-rw``)."""
    integrator: str | None = None
    """A name in ``rbenv.core.INTEGRATORS``; unset: the scene's ``[physics]`` integrator (rk4:
    cubesat-12u, cubesat-12u-dr, cubesat-12u-rw, cubesat-6u-rw, innocube-3u; midpoint:
    microsat-100kg, boom-sat)."""
    control_dt: float | None = None
    """Seconds of one env step; unset: the scene's."""
    substeps: int | None = None
    """Integrator steps per control step; unset: the scene's."""
    action_mode: str = "throttle"
    """``"throttle"``, ``"on_off"``, ``"torque"``, ``"acceleration"`` (wheels: the wheel
    acceleration as a fraction of the scene's command clamp) or ``"acceleration_lifted"`` (the
    same, lifted over the wheels' deadband: below a quarter of its upper bound zero, else at
    least it)."""
    reward_weights: dict | None = None
    """A dict overriding the task's reward weights (each task's docstring lists them)."""
    max_initial_angle_deg: float | None = None
    """Initial attitude error up to this angle (a curriculum); unset: the scene's."""
    max_initial_rate: float | None = None
    """Initial tumble up to this rate, rad/s; unset: the scene's."""
    allocator: str = "pinv"
    """Torque mode's allocator: ``"pinv"``, ``"nnls"`` or ``"lp"``."""
    randomize: dict | bool | None = None
    """A dict of domain-randomization sizes (``rbenv.Randomization``), or False; unset: the
    scene's (on: cubesat-12u-dr; off: every other shipped scene)."""
    task_options: dict | None = None
    """A dict overriding the scene's ``[tasks.<task>]`` table (detumble, track, desaturate)."""
    compiled: bool = False
    """True: the integrator runs numba-compiled (extra ``rbenv[fast]``; rk4, euler,
    semi_implicit or euler_seed, not midpoint or splitting; not with randomized inertia): the
    same results bit for bit, after a few seconds of compilation at the first step."""


@dataclasses.dataclass(frozen=True)
class BackendOptions:
    """The options that choose the array backend (``rbenv.envs.torch_env`` holds the torch envs and
    takes the torch ones; tests/rbenv/test_options.py holds their defaults equal to its)."""

    backend: str = "numpy"
    """``"numpy"`` (Python floats for one satellite, NumPy arrays for N) or ``"torch"`` (the
    same transition on torch tensors; needs torch, from the ``train`` extra)."""
    device: str = "cpu"
    """torch only: the torch device of the state, actions and observations (``"cuda"``, ...)."""
    dtype: str = "float64"
    """torch only: ``"float64"`` or ``"float32"`` (or the torch dtype), the float type the torch
    env computes and observes in."""
    compile: bool = False
    """torch only: run the step under ``torch.compile`` (eager fallback with a warning where it
    cannot)."""
    check_every: int = 1
    """torch only: steps between the checks for a non-finite state (0: only at reset and on
    ``check()``); every step by default, as the NumPy env."""


@dataclasses.dataclass(frozen=True)
class ShellOptions:
    """What the shells take besides the env options: the render mode and the task entry."""

    render_mode: str | None = None
    """``"rgb_array"`` or ``"human"`` (single env)"""
    task: object = None
    """The :class:`rbenv.tasks.spec.TaskSpec` to run; unset: the class's own (each shipped id's
    class has one; ``gym.make`` passes it for an id registered without classes)."""


@dataclasses.dataclass(frozen=True)
class VectorOptions:
    """What a vector env (``gym.make_vec``) adds to the single env's options."""

    num_envs: int = 1
    """Number of sub-envs."""
    max_episode_steps: int | None = None
    """Steps per episode, at most the scene's (``make_vec`` passes the registered value)."""
    autoreset_mode: object = None
    """An ``AutoresetMode`` or its value; unset: :data:`AUTORESET_DEFAULT`."""


ENV_OPTIONS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(EnvOptions))
BACKEND_OPTIONS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(BackendOptions))
TORCH_OPTIONS: tuple[str, ...] = tuple(n for n in BACKEND_OPTIONS if n != "backend")
SHELL_OPTIONS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(ShellOptions))
VECTOR_OPTIONS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(VectorOptions))

# The options each shell takes (rbenv.envs.env, vector_env, torch_env, goal). ``backend``
# is no shell's: the entry points of rbenv.envs.registry take it and pick the shell.
OPTIONS_OF: dict[str, tuple[str, ...]] = {
    "single": (*ENV_OPTIONS, *SHELL_OPTIONS),
    "numpy": (*ENV_OPTIONS, *SHELL_OPTIONS, *VECTOR_OPTIONS),
    "torch": (*ENV_OPTIONS, *SHELL_OPTIONS, *VECTOR_OPTIONS, *TORCH_OPTIONS),
    "torch_single": (*ENV_OPTIONS, *SHELL_OPTIONS, *TORCH_OPTIONS),
    "goal": (*ENV_OPTIONS, "render_mode"),  # the goal form is Reorient-v1's, NumPy
}

# The vector envs' autoreset mode when ``autoreset_mode`` is not given, on every backend; the
# one place that says it (each vector env reads it when made): NEXT_STEP, Gymnasium's own
# default (SyncVectorEnv's). The torch env runs it without a host read on a GPU, as SAME_STEP.
AUTORESET_DEFAULT: AutoresetMode = AutoresetMode.NEXT_STEP
DEFAULTS: dict = {f.name: f.default for f in dataclasses.fields(EnvOptions)}
_ALL_DEFAULTS: dict = {f.name: f.default for cls in (EnvOptions, ShellOptions, VectorOptions,
                                                     BackendOptions)
                       for f in dataclasses.fields(cls)}


def take(owner: str, shell: str, given: dict) -> dict:
    """The keyword arguments ``given`` to the constructor of ``owner`` (a class name), a shell
    of :data:`OPTIONS_OF`, completed with the declared defaults: name -> value for every option
    that shell takes. An unknown name raises Python's own TypeError (see
    :func:`unknown_options`)."""
    names = OPTIONS_OF[shell]
    unknown = set(given).difference(names)
    if unknown:
        hint = "" if unknown.isdisjoint(("num_envs", "autoreset_mode")) else \
            " (num_envs and autoreset_mode are a batch's: gym.make_vec(ID, num_envs=N, ...))"
        unknown_options(owner, unknown, names, hint)
    return {name: given.get(name, _ALL_DEFAULTS[name]) for name in names}


def unknown_options(owner: str, unknown, valid, hint: str = "") -> None:
    """Raise the TypeError of an unexpected keyword, naming the valid ones.

    The message begins as Python's own ("got an unexpected keyword argument 'frameskip'"):
    clients match it to retry without an option the env does not take (TorchRL's ``GymEnv``
    drops ``frameskip`` so)."""
    first, *rest = sorted(unknown)
    more = f" (and {', '.join(repr(k) for k in rest)})" if rest else ""
    raise TypeError(f"{owner}.__init__() got an unexpected keyword argument {first!r}{more}; "
                    f"the valid options are {', '.join(sorted(valid))}{hint}")


@cache
def field_docs(cls: type) -> dict[str, str]:
    """``{field: docstring}`` of a dataclass and its bases: the string literal under each field,
    its whitespace collapsed."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if not dataclasses.is_dataclass(klass):
            continue
        body = ast.parse(textwrap.dedent(inspect.getsource(klass))).body[0].body
        for node, after in itertools.pairwise(body):
            if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
                    and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)
                    and isinstance(after.value.value, str)):
                docs[node.target.id] = " ".join(after.value.value.split())
    return docs


def default_text(name: str) -> str:
    """How a default reads in the tables: ``"throttle"``, False, or "unset"."""
    value = DEFAULTS[name]
    return "unset" if value is None else (f'"{value}"' if isinstance(value, str) else repr(value))


def _rows() -> list[tuple[str, str, str]]:
    docs = field_docs(EnvOptions)
    rows = [(name, default_text(name), docs[name]) for name in ENV_OPTIONS]
    return [*rows, ("render_mode", "unset", field_docs(ShellOptions)["render_mode"])]


def options_table(indent: str = "    ") -> str:
    """The Arguments table of the env docstrings (reStructuredText), from :class:`EnvOptions`."""
    rows = [(f"``{n}``", f"``{d}``" if d.startswith('"') else d, m) for n, d, m in _rows()]
    widths = [max(len(r[i]) for r in rows) for i in range(2)]
    rule = f"{'=' * widths[0]}  {'=' * widths[1]}  {'=' * 50}"
    lines = [rule, f"{'argument':<{widths[0]}}  {'default':<{widths[1]}}  meaning", rule]
    for name, default, meaning in rows:
        wrapped = textwrap.wrap(meaning, 50, break_on_hyphens=False) or [""]
        lines.append(f"{name:<{widths[0]}}  {default:<{widths[1]}}  {wrapped[0]}")
        pad = " " * (widths[0] + widths[1] + 4)
        lines += [pad + more for more in wrapped[1:]]
    lines.append(rule)
    return "\n".join((indent + line).rstrip() for line in lines)


def _backend_rows() -> list[tuple[str, str, str]]:
    docs = field_docs(BackendOptions)
    rows = []
    for f in dataclasses.fields(BackendOptions):
        default = f'"{f.default}"' if isinstance(f.default, str) else repr(f.default)
        rows.append((f.name, default, docs[f.name]))
    return rows


def options_markdown() -> str:
    """The same table in Markdown, as docs/api.md holds it, with the backend options
    (:class:`BackendOptions`) after the env's."""
    lines = ["| argument | default | meaning |", "|---|---|---|"]
    lines += [f"| `{n}` | {f'`{d}`' if d.startswith(chr(34)) else d} | "
              f"{m.replace('``', '`')} |" for n, d, m in [*_rows(), *_backend_rows()]]
    return "\n".join(lines)
