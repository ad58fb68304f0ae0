"""Fuzz rbenv's input boundaries as a hostile user would, and tally what each probe gets back.

Every probe is one call with one bad, extreme or unusual input. It is classified as:

* ``clear error``: a ``rbenv.core.errors.RbenvValueError`` (or, for a wrong type, a ``TypeError``)
  whose message names the field;
* ``unclear error``: any other exception (``TypeError``, ``OverflowError``, ``LinAlgError``,
  ``RecursionError``, a numpy broadcasting message, or a named error that omits the field);
* ``silently accepted``: an input the documentation forbids came back without an error;
* ``non-finite out``: the call returned NaN or inf somewhere in its output, or an orientation
  that is not a unit quaternion (overflow turned into a plausible zero);
* ``hang or crash``: no answer within the per-probe time limit, or ``MemoryError`` under the
  address-space cap;
* ``accepted, finite``: a legal (or extreme but legal) input gave finite output, as it should;
* ``valid refused``: a legal input (``np.int64``, an empty batch, ...) raised.

Rows: ``core API`` (core, inertia, meshes), ``env options`` (``gym.make`` options, ``reset``
options, actions, ``make_vec``), ``mutated scene TOML`` (random mutations of the shipped scenes,
loaded and stepped), ``env at numerical extremes``, ``torch backend options`` (``backend="torch"``
of ``make_vec`` and ``make``: device, dtype, compile, check_every, what it refuses, actions,
seeds and reset masks; where torch is installed). Seeded and bounded: the same command gives
the same probes. Run it against any checkout::

    python benchmarks/fuzz.py --out benchmarks/results/fuzz_after.json
    PYTHONPATH=/path/to/old/checkout python benchmarks/fuzz.py --out fuzz_before.json

The JSON holds the counts of every row and the probes whose class is not a right answer
(``clear error``, ``accepted, finite``), each with its input and what it got back;
``--all-probes`` lists every probe.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import random  # noqa: E402
import resource  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

COLUMNS = ("clear error", "unclear error", "silently accepted", "non-finite out",
           "hang or crash", "accepted, finite", "valid refused")
ANSWERS = ("clear error", "accepted, finite")  # the right outcomes; the JSON lists the others
ROWS = ("core API", "env options", "mutated scene TOML", "env at numerical extremes",
        "torch backend options")
INVALID, VALID, EITHER = "invalid", "valid", "either"


class ProbeTimeout(BaseException):
    """Raised by the alarm: the probe did not return in time (BaseException: not caught)."""


def _alarm(signum, frame):
    raise ProbeTimeout


# --------------------------------------------------------------------------- outcome checks


def _all_finite(value, depth=0) -> bool:
    """True when every number reachable in ``value`` is finite (bounded walk)."""
    if depth > 6:
        return True
    if isinstance(value, (bool, np.bool_, str, bytes)) or value is None:
        return True
    if isinstance(value, (int, float, np.integer, np.floating)):
        return bool(np.isfinite(float(value))) if not isinstance(value, int) else True
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "fc":
            return bool(np.isfinite(value).all())
        if value.dtype.kind == "O":
            return all(_all_finite(v, depth + 1) for v in value.flat[:1000])
        return True
    if isinstance(value, dict):
        return all(_all_finite(v, depth + 1) for v in list(value.values())[:200])
    if isinstance(value, (list, tuple)):
        return all(_all_finite(v, depth + 1) for v in value[:200])
    if hasattr(value, "orientation") and hasattr(value, "angular_velocity"):
        q = np.asarray(value.orientation, dtype=float)
        if q.size and not np.allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-6):
            return False  # a zero or non-unit quaternion is overflow, not an attitude
    fields = getattr(value, "__dataclass_fields__", None)
    if fields:
        return all(_all_finite(getattr(value, f, None), depth + 1) for f in fields)
    return True


def run_probe(fn, expect: str, fields: tuple, timeout: float) -> tuple[str, str]:
    """Call ``fn()`` under an alarm; return (column, detail)."""
    from rbenv.core.errors import RbenvValueError

    signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with np.errstate(all="ignore"):
                out = fn()
        finite = _all_finite(out)
    except ProbeTimeout:
        return "hang or crash", f"no answer within {timeout} s"
    except (MemoryError, SystemError) as exc:
        return "hang or crash", f"{type(exc).__name__}"
    except Exception as exc:
        signal.setitimer(signal.ITIMER_REAL, 0)
        text = str(exc)
        detail = f"{type(exc).__name__}: {text[:160]}"
        # A TypeError for a wrong type is clear too when it names the field (Gymnasium's
        # convention, kept by rbenv's actions and reset masks).
        named = isinstance(exc, (RbenvValueError, TypeError)) and any(
            f.lower() in text.lower() for f in fields)
        if expect == VALID:
            return "valid refused", detail
        return ("clear error" if named else "unclear error"), detail
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    if not finite:
        return "non-finite out", "output contains NaN or inf"
    if expect == INVALID:
        return "silently accepted", "no error"
    return "accepted, finite", ""


# --------------------------------------------------------------------------- value pools

NAN, INF = float("nan"), float("inf")
FULL = object()  # action sentinel: every entry at the top of the action space


def scalar_pool():
    """(value, expect) for a strictly positive scalar field."""
    return [
        (True, INVALID), ("1.0", INVALID), (1 + 2j, INVALID), ({"a": 1}, INVALID),
        (None, INVALID), ([1.0], INVALID), (NAN, INVALID), (INF, INVALID), (-INF, INVALID),
        (-1.0, INVALID), (0.0, INVALID), (10**400, INVALID), (np.complex128(1 + 1j), INVALID),
        (1e308, EITHER), (1e-310, EITHER), (np.int64(2), VALID), (np.float32(0.5), VALID),
    ]


def vector_pool(width=3, valid=0.0):
    """(value, expect) for a (width,) vector field; ``valid``: a legal entry value."""
    z = [0.0] * width
    return [
        ([True] * width, INVALID), (["1"] * width, INVALID), ([1j, *z[1:]], INVALID),
        ({"x": 1.0}, INVALID), ([[1.0, 2.0], [3.0]], INVALID), (z[:-1], INVALID),
        ([NAN, *z[1:]], INVALID), ([INF, *z[1:]], INVALID), ([10**400, *z[1:]], INVALID),
        ("abc", INVALID), (np.full(width, valid, dtype=np.float32), VALID),
        (np.full(width, int(valid), dtype=np.int64), VALID),
    ]


def quaternion_pool():
    return [
        ([1.0, 0, 0], INVALID), ([0.0] * 4, INVALID), ([2.0, 0, 0, 0], INVALID),
        ([NAN, 0, 0, 0], INVALID), ([True, False, False, False], INVALID),
        (["1", "0", "0", "0"], INVALID), ([1j, 0, 0, 0], INVALID), ({"w": 1}, INVALID),
        ([1e200, 0, 0, 0], INVALID), (np.array([1, 0, 0, 0], dtype=np.float32), VALID),
        (np.array([1, 0, 0, 0], dtype=np.int64), VALID),
    ]


def matrix_pool():
    eye = np.eye(3)
    return [
        (eye.astype(bool), INVALID), (eye * 1j, INVALID), ("eye", INVALID), (eye[:2, :2], INVALID),
        (eye * NAN, INVALID), (-eye, INVALID), (np.diag([1.0, 1.0, 3.0]), INVALID),
        ({"xx": 1}, INVALID), (eye * 1e308, EITHER), (eye * 1e-310, EITHER),
        (np.diag([1e-300, 1.0, 1.0]), INVALID), (eye.astype(np.float32), VALID),
        (eye.astype(np.int64), VALID), ([[1, 0, 0], [0, 1, 0], [0, 0, 10**400]], INVALID),
    ]


def integer_pool():
    return [
        (-1, INVALID), (2.5, INVALID), (True, INVALID), ("3", INVALID), (NAN, INVALID),
        (INF, INVALID), (None, INVALID), (np.int64(3), VALID), (3, VALID),
    ]


# --------------------------------------------------------------------------- core probes


def core_probes(tmp: Path):
    from rbenv.core import BodyState, RigidBody, ThrusterLayout, inertia, quaternion, simulate, step

    from rbenv import core

    body = RigidBody(mass=1.0, inertia=np.diag([1.0, 2.0, 2.5]))
    iso = RigidBody(mass=1.0, inertia=np.eye(3))
    state = BodyState(angular_velocity=[0.1, 0.2, 0.3])
    batch = BodyState(angular_velocity=np.full((3, 3), 0.1))
    probes = []

    def add(target, fields, value, expect, fn):
        probes.append(("core API", target, fields, value, expect, fn))

    for v, e in scalar_pool():
        add("RigidBody.mass", ("mass",), v, e, lambda v=v: RigidBody(mass=v, inertia=np.eye(3)))
        add("step.dt", ("dt",), v, e, lambda v=v: step(body, state, v))
        add("inertia.solid_sphere.radius", ("radius",), v, e,
            lambda v=v: inertia.solid_sphere(1.0, v))
        add("inertia.solid_cylinder.height", ("height",), v, e,
            lambda v=v: inertia.solid_cylinder(1.0, 0.5, v))
        add("inertia.parallel_axis.mass", ("mass",), v, EITHER if v == 0.0 else e,
            lambda v=v: inertia.parallel_axis(np.eye(3), v, [1.0, 0, 0]))
    for v, e in matrix_pool():
        add("RigidBody.inertia", ("inertia",), v, e, lambda v=v: RigidBody(mass=1.0, inertia=v))
        add("inertia.validate", ("inertia",), v, e, lambda v=v: inertia.validate(v))
        physical = isinstance(v, np.ndarray) and v.dtype.kind == "f" and np.isfinite(v).all()
        add("inertia.principal_axes", ("inertia",), v, EITHER if physical else e,
            lambda v=v: inertia.principal_axes(v))
    for name in ("position", "velocity", "angular_velocity"):
        for v, e in vector_pool():
            add(f"BodyState.{name}", (name,), v, e, lambda v=v, n=name: BodyState(**{n: v}))
        add(f"BodyState.{name}", (name,), "empty batch", VALID,
            lambda n=name: BodyState(**{n: np.zeros((0, 3))}))
    for v, e in quaternion_pool():
        add("BodyState.orientation", ("orientation",), v, e, lambda v=v: BodyState(orientation=v))
        add("quaternion.normalize", ("quaternion", "q"),
            v, VALID if e == VALID or v == [2.0, 0, 0, 0] or v == [1e200, 0, 0, 0] else e,
            lambda v=v: quaternion.normalize(v))
    add("BodyState", ("shape", "batch"), "mismatched batches", INVALID,
        lambda: BodyState(position=np.zeros((2, 3)), angular_velocity=np.zeros((3, 3))))
    for load in ("torque", "force", "torque_B"):
        for v, e in vector_pool():
            add(f"step.{load}", (load,), v, e, lambda v=v, k=load: step(body, state, 0.1, **{k: v}))
        add(f"step.{load}", (load, "batch"), "mismatched batch", INVALID,
            lambda k=load: step(body, batch, 0.1, **{k: np.zeros((2, 3))}))
        add(f"step.{load}", (load, "diverged"), "1e300", EITHER,
            lambda k=load: step(body, state, 0.1, **{k: [1e300, 1e300, 0.0]}))
    add("step", ("batch",), "empty batch", VALID,
        lambda: step(body, BodyState(angular_velocity=np.zeros((0, 3))), 0.1,
                     torque=np.zeros((0, 3))))
    for v in ("nope", 1, None, True, ""):
        add("step.integrator", ("integrator",), v, INVALID,
            lambda v=v: step(body, state, 0.1, integrator=v))
    for v, e in [*integer_pool(), (10**12, INVALID), (3.0, EITHER)]:
        add("simulate.n_steps", ("n_steps",), v, e, lambda v=v: simulate(body, state, 0.1, v))
    for integ in ("midpoint", "rk4", "euler", "semi_implicit", "euler_seed"):
        for b, label in ((iso, "isotropic"), (body, "full")):
            add(f"step dt=1e160 {integ} {label}", ("dt", "integrator", "diverged", "overflow"),
                1e160, EITHER, lambda b=b, i=integ: step(b, state, 1e160, integrator=i))
        add(f"step |ω|=1e200 {integ}", ("diverged", "overflow"), 1e200, EITHER,
            lambda i=integ: step(body, BodyState(angular_velocity=[1e200, 0, 1e200]), 0.1,
                                 integrator=i))
        add(f"simulate dt=1e3 {integ}", ("diverged", "overflow"), 1e3, EITHER,
            lambda i=integ: simulate(body, state, 1e3, 50, integrator=i))
    add("step translation overflow", ("diverged", "overflow", "position", "velocity"), 1e300,
        EITHER, lambda: step(body, BodyState(velocity=[1e300, 0, 0]), 1e10))
    for v, e in vector_pool(valid=1.0):
        add("inertia.solid_box.size", ("size",), v, e, lambda v=v: inertia.solid_box(1.0, v))
    for v, e in vector_pool():
        add("inertia.parallel_axis.offset", ("offset",), v, e,
            lambda v=v: inertia.parallel_axis(np.eye(3), 1.0, v))
    for v in ("base", 1, None, True):
        add("inertia.solid_cone.about", ("about",), v, INVALID,
            lambda v=v: inertia.solid_cone(1.0, 1.0, 1.0, about=v))
    for v, e in [*integer_pool(), (10**6, INVALID), (0, INVALID)]:
        add("inertia.box_particles.n", ("n",), v, e,
            lambda v=v: inertia.box_particles(1.0, [1, 1, 1], v))
    add("inertia.solid_sphere overflow", ("solid_sphere", "mass", "overflow"), 1e200, EITHER,
        lambda: inertia.solid_sphere(1e200, 1e200))
    add("inertia.from_particles", ("positions",), "bool", INVALID,
        lambda: inertia.from_particles([1.0, 1.0], np.ones((2, 3), dtype=bool)))
    add("inertia.from_particles", ("masses",), "strings", INVALID,
        lambda: inertia.from_particles(["1", "1"], np.eye(3)[:2]))
    # thruster layouts
    pos, dirs = np.eye(3), np.eye(3)
    for v, e in [*scalar_pool(), ([True, True, True], INVALID), ([1.0, 1.0], INVALID)]:
        add("ThrusterLayout.max_force", ("max_force",), v, e,
            lambda v=v: ThrusterLayout(positions_B=pos, directions_B=dirs[::-1], max_force=v))
    for v, e in [(np.zeros((0, 3)), INVALID), (np.ones((100_000, 3)), INVALID),
                 (np.full((3, 3), "1"), INVALID), (np.eye(3) * 1j, INVALID)]:
        add("ThrusterLayout.positions_B", ("positions_b", "thruster"), "array", e,
            lambda v=v: ThrusterLayout(positions_B=v, directions_B=np.ones_like(v, dtype=float)
                                       if np.asarray(v).dtype.kind in "f" else dirs,
                                       max_force=1.0))
    # meshes
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    add("inertia.from_mesh unused far vertex", ("mesh",), "far vertex", VALID,
        lambda: inertia.from_mesh(np.vstack([v, [1e6, 1e6, 1e6]]), f, mass=1.0))
    add("inertia.from_mesh faces", ("faces",), "float faces", INVALID,
        lambda: inertia.from_mesh(v, f.astype(float), mass=1.0))
    add("inertia.from_mesh faces", ("faces",), "index out of range", INVALID,
        lambda: inertia.from_mesh(v, f + 3, mass=1.0))
    add("inertia.from_mesh mass", ("mass",), True, INVALID,
        lambda: inertia.from_mesh(v, f, mass=True))
    fifo = tmp / "pipe.stl"
    os.mkfifo(fifo)
    zero = tmp / "zero.stl"
    zero.symlink_to("/dev/zero")
    folder = tmp / "folder.obj"
    folder.mkdir()
    bad_utf8 = tmp / "bad.obj"
    bad_utf8.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n\xff\xfe\nf 1 3 2\nf 1 2 4\n"
                         b"f 1 4 3\nf 2 3 4\n")
    header = tmp / "header.stl"
    header.write_bytes(b"\0" * 80 + np.uint32(4_000_000_000).tobytes() + b"\0" * 50)
    for path, e in ((fifo, INVALID), (zero, INVALID), (folder, INVALID), (bad_utf8, EITHER),
                    (header, INVALID), (tmp / "missing.stl", INVALID)):
        add("inertia.load_mesh", ("mesh", str(path)), path.name, e,
            lambda p=path: inertia.load_mesh(p))
    del core
    return probes


# --------------------------------------------------------------------------- env probes


def _episode(env_id="rbenv/SatelliteReorient-v0", steps=3, reset_options=None, action=None,
             **kwargs):
    import gymnasium as gym

    env = gym.make(env_id, **kwargs)
    try:
        out = [env.reset(seed=0, options=reset_options)]
        for _ in range(steps):
            a = {id(None): env.action_space.high * 0, id(FULL): env.action_space.high}.get(
                id(action), action)
            out.append(env.step(a))
            if out[-1][2] or out[-1][3]:
                break
        return out
    finally:
        env.close()


def _vec_episode(num_envs=2, steps=2, action=None, **kwargs):
    import gymnasium as gym

    envs = gym.make_vec("rbenv/SatelliteReorient-v0", num_envs=num_envs, **kwargs)
    try:
        out = [envs.reset(seed=0)]
        for _ in range(steps):
            a = np.zeros(envs.action_space.shape, np.float32) if action is None else action
            out.append(envs.step(a))
        return out
    finally:
        envs.close()


def env_probes():
    probes = []

    def add(target, fields, value, expect, fn):
        probes.append(("env options", target, fields, value, expect, fn))

    for v, e in scalar_pool():
        e = VALID if v is None else e  # None: the scene's value
        add("gym.make control_dt", ("control_dt",), v, e, lambda v=v: _episode(control_dt=v))
    for v, e in [*scalar_pool()[:10], (0.0, VALID), (1.0, INVALID), (np.float32(0.01), VALID),
                 (np.int64(0), VALID), (1e-310, EITHER)]:
        e = VALID if v is None else e
        add("gym.make max_initial_rate", ("max_initial_rate",), v, e,
            lambda v=v: _episode(max_initial_rate=v))
    for v, e in [(np.int64(30), VALID), (np.float32(30.0), VALID), (30, VALID), (1e308, INVALID),
                 (-1.0, INVALID), (True, INVALID), ("30", INVALID), (NAN, INVALID),
                 (1 + 1j, INVALID), ({"deg": 30}, INVALID), (181.0, INVALID)]:
        add("gym.make max_initial_angle_deg", ("max_initial_angle_deg",), v, e,
            lambda v=v: _episode(max_initial_angle_deg=v))
    for v, e in [*integer_pool(), (10_000_000, INVALID), (0, INVALID)]:
        e = VALID if v is None else e
        add("gym.make substeps", ("substeps",), v, e, lambda v=v: _episode(substeps=v))
    for key in ("integrator", "action_mode", "allocator", "render_mode"):
        for v in ("nope", 1, True, {"a": 1}):
            add(f"gym.make {key}", (key,), v, INVALID, lambda v=v, k=key: _episode(**{k: v}))
    for v in (123, "no-such-scene", {"name": "x"}, Path("/dev/zero"), "/etc/passwd", True):
        add("gym.make scene", ("scene",), v, INVALID, lambda v=v: _episode(scene=v))
    for v, e in [({"fuel": True}, INVALID), ({"fuel": "0.1"}, INVALID),
                 ({"fuel": NAN}, INVALID), ({"fuel": -1.0}, INVALID), ({"nope": 1.0}, INVALID),
                 ("fuel", INVALID), ({"fuel": 1e308}, EITHER), ({"fuel": np.float32(0.1)}, VALID),
                 ({"hold": np.int64(2)}, VALID), ({"fuel": 1 + 1j}, INVALID),
                 ({"fuel": {"x": 1}}, INVALID)]:
        add("gym.make reward_weights", ("reward_weights", "fuel", "hold", "nope"), v, e,
            lambda v=v: _episode(reward_weights=v))
    for key, pool in (("q", quaternion_pool()), ("q_target", quaternion_pool()),
                      ("omega_B", vector_pool())):
        for v, e in pool:
            add(f"reset options {key}", (key,), v, e,
                lambda v=v, k=key: _episode(reset_options={k: v}))
    add("reset options omega_B", ("omega_b", "omega"), 1e200, EITHER,
        lambda: _episode(reset_options={"omega_B": [1e200, 0, 0]}))
    add("reset options", ("options", "nope"), {"nope": 1}, INVALID,
        lambda: _episode(reset_options={"nope": 1}))
    add("reset options", ("options",), "a string", INVALID,
        lambda: _episode(reset_options="q"))
    for v, e in [(np.full(12, NAN, np.float32), INVALID), (np.zeros(11, np.float32), INVALID),
                 ("fire", INVALID), ({"a": 1}, INVALID), (np.full(12, 1e30), EITHER),
                 (np.full(12, INF), INVALID), (np.zeros(12, bool), EITHER)]:
        add("env.step action", ("action",), v, e, lambda v=v: _episode(action=v))
    for v, e in [(0, EITHER), (-1, INVALID), (True, INVALID), (2.5, INVALID), ("2", INVALID),
                 (np.int64(2), VALID), (10**12, INVALID)]:
        add("gym.make_vec num_envs", ("num_envs",), v, e, lambda v=v: _vec_episode(num_envs=v))
    add("vector env step action", ("action", "shape"), "wrong batch", INVALID,
        lambda: _vec_episode(num_envs=3, action=np.zeros((2, 12), np.float32)))
    add("vector env step action", ("action",), "NaN", INVALID,
        lambda: _vec_episode(num_envs=2, action=np.full((2, 12), NAN, np.float32)))
    return probes


def _torch_episode(num_envs=2, steps=2, action=None, reset=None, env_id=None, **kwargs):
    """A short torch-backend rollout, returned as NumPy (so finiteness is checked)."""
    import gymnasium as gym
    import torch

    envs = gym.make_vec(env_id or "rbenv/SatelliteReorient-v0", num_envs=num_envs,
                        backend="torch", **kwargs)
    try:
        out = [envs.reset(**(reset or {"seed": 0}))]
        for _ in range(steps):
            a = torch.zeros(envs.action_space.shape, dtype=torch.float64) if action is None \
                else action() if callable(action) else action
            out.append(envs.step(a))
        return [tuple(_numpy(x) for x in o) for o in out]
    finally:
        envs.close()


def _numpy(x):
    import torch

    if isinstance(x, torch.Tensor):
        return x.detach().cpu().numpy()
    if isinstance(x, dict):
        return {k: _numpy(v) for k, v in x.items()}
    return x


def torch_probes():
    """``backend="torch"``: its own options, what it refuses, actions, seeds and masks."""
    try:
        import torch
    except ImportError:
        return []
    probes = []

    def add(target, fields, value, expect, fn):
        probes.append(("torch backend options", target, fields, value, expect, fn))

    for v, e in [("cpu", VALID), (torch.device("cpu"), VALID), ("cuda:7", INVALID),
                 ("nope", INVALID), (3, INVALID), (None, INVALID)]:
        add("make_vec device", ("device",), v, e, lambda v=v: _torch_episode(device=v))
    for v, e in [("float32", VALID), ("float16", INVALID), (torch.float64, VALID),
                 (torch.float16, INVALID),
                 ("float", INVALID), (None, INVALID)]:
        add("make_vec dtype", ("dtype",), v, e, lambda v=v: _torch_episode(dtype=v))
    for v, e in [("yes", INVALID), (2, INVALID), (None, INVALID)]:
        add("make_vec compile", ("compile",), v, e, lambda v=v: _torch_episode(compile=v))
    for v, e in [(0, VALID), (10**9, VALID), (-1, INVALID), (1.5, INVALID), ("1", INVALID),
                 (True, INVALID)]:
        add("make_vec check_every", ("check_every",), v, e,
            lambda v=v: _torch_episode(check_every=v))
    for v, e in [(1, VALID), (0, INVALID), (-3, INVALID), (2**25, INVALID), (2.5, INVALID)]:
        add("make_vec num_envs", ("num_envs",), v, e, lambda v=v: _torch_episode(num_envs=v))
    for key, v in [("integrator", "midpoint"), ("integrator", "splitting"),
                   ("action_mode", "torque"), ("render_mode", "rgb_array"),
                   ("compiled", True)]:
        add(f"make_vec {key} (not supported)", (key,), v, INVALID,
            lambda k=key, v=v: _torch_episode(**{k: v}))
    add("make_vec scene (randomized)", ("randomiz",), "cubesat-12u-dr", INVALID,
        lambda: _torch_episode(scene="cubesat-12u-dr"))
    add("make_vec scene (per-step noise)", ("noise",), "boom-sat", INVALID,
        lambda: _torch_episode(scene="boom-sat", integrator="rk4"))
    add("make_vec env id (desaturate)", ("desaturat",), "SatelliteDesaturate-v0", INVALID,
        lambda: _torch_episode(env_id="rbenv/SatelliteDesaturate-v0"))
    n = 2
    for name, v, e in [("numpy array", np.zeros((n, 12)), INVALID),
                       ("wrong shape", torch.zeros(n, 11), INVALID),
                       ("one row", torch.zeros(12), INVALID),
                       ("NaN", torch.full((n, 12), NAN), INVALID),
                       ("complex", torch.zeros(n, 12, dtype=torch.complex128), INVALID),
                       ("int", torch.zeros(n, 12, dtype=torch.int64), VALID),
                       ("bool", torch.zeros(n, 12, dtype=torch.bool), EITHER),
                       ("inf", torch.full((n, 12), INF), EITHER),
                       ("float32", torch.zeros(n, 12, dtype=torch.float32), VALID),
                       ("None", None, INVALID), ("list", [[0.0] * 12] * n, INVALID)]:
        act = (lambda: None) if v is None else v
        add("vector step actions", ("action",), name, e,
            lambda act=act: _torch_episode(num_envs=n, action=act))
    for name, reset, e in [
            ("seed -1", {"seed": -1}, INVALID), ("seed 1.5", {"seed": 1.5}, INVALID),
            ("seed 2**63", {"seed": 2**63}, INVALID), ("seed list short", {"seed": [1]}, INVALID),
            ("seed list", {"seed": [3, 4]}, VALID), ("seed str", {"seed": "0"}, INVALID),
            ("reset_mask numpy", {"options": {"reset_mask": np.ones(n, bool)}}, INVALID),
            ("reset_mask int", {"options": {"reset_mask": torch.ones(n, dtype=torch.int64)}},
             INVALID),
            ("reset_mask shape", {"options": {"reset_mask": torch.ones(n + 1, dtype=torch.bool)}},
             INVALID),
            ("reset_mask all False", {"options": {"reset_mask": torch.zeros(n, dtype=torch.bool)}},
             INVALID)]:
        fields = ("seed",) if "seed" in name else ("reset_mask",)
        add("vector reset", fields, name, e,
            lambda reset=reset: _torch_mask_reset(n, reset) if "options" in reset
            else _torch_episode(num_envs=n, reset=reset))
    for v, e in [("jax", INVALID), (None, INVALID), ("torch", VALID)]:
        add("gym.make backend", ("backend",), v, e, lambda v=v: _episode(backend=v))
    add("gym.make backend=torch num_envs", ("num_envs",), 4, INVALID,
        lambda: _episode(backend="torch", num_envs=4))
    return probes


def _torch_mask_reset(n, reset):
    """A DISABLED-autoreset torch env, reset once in full, then with ``reset``'s mask."""
    import gymnasium as gym

    envs = gym.make_vec("rbenv/SatelliteReorient-v0", num_envs=n, backend="torch",
                        autoreset_mode="Disabled")
    try:
        envs.reset(seed=0)
        return _numpy(envs.reset(**reset))
    finally:
        envs.close()


def extreme_probes():
    """The env at numerical extremes: named error or clean, finite episodes."""
    probes = []

    def add(target, fields, value, fn):
        probes.append(("env at numerical extremes", target, fields, value, EITHER, fn))

    fields = ("diverged", "overflow", "control_dt", "omega", "rate", "substeps", "dt")
    for integ in ("midpoint", "rk4", "euler", "semi_implicit", "euler_seed"):
        for dt in (1e3, 1e6, 1e160):
            add(f"{integ} control_dt={dt:g}", fields, dt,
                lambda i=integ, d=dt: _episode(integrator=i, control_dt=d, steps=3))
        for w in (10.0, 1e3, 1e8, 1e200):
            add(f"{integ} omega_B={w:g}", fields, w,
                lambda i=integ, w=w: _episode(integrator=i, steps=3,
                                              reset_options={"omega_B": [w, -w, 0.5 * w]}))
    for scene in ("cubesat-12u", "microsat-100kg", "boom-sat"):
        for mode in ("throttle", "torque", "on_off"):
            add(f"{scene} {mode} full action", fields, 1.0,
                lambda s=scene, m=mode: _episode(scene=s, action_mode=m, steps=20, action=FULL))
    add("substeps 1000 control_dt 20", fields, 1000, lambda: _episode(substeps=1000,
                                                                     control_dt=20.0))
    return probes


# --------------------------------------------------------------------------- mutated TOML


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def dump_toml(data: dict) -> str:
    lines = [f"{json.dumps(k)} = {_toml_value(v)}" for k, v in data.items()
             if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            lines.append(f"\n[{json.dumps(k)}]")
            lines.extend(f"{json.dumps(kk)} = {_toml_value(vv)}" for kk, vv in v.items())
    return "\n".join(lines) + "\n"


def _leaves(obj, path=()):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(obj, list) and obj and isinstance(obj[0], (list, dict)):
        for i, v in enumerate(obj):
            yield from _leaves(v, (*path, i))
    else:
        yield path, obj


def _set(obj, path, value):
    for p in path[:-1]:
        obj = obj[p]
    if value is _DELETE:
        del obj[path[-1]]
    else:
        obj[path[-1]] = value


_DELETE = object()
_EXTREMES = [0, -1, -1.0, 1e308, -1e308, 1e-310, 1e160, 1e-160, 10**30, 2**63 - 1, 1e6, 1e-9,
             1e200, 3]
_TYPES = [True, False, "1.0", {"a": 1.0}, [], [1.0]]


def _number_like(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def toml_mutations(scenes: dict, n: int, rng: random.Random):
    """Yield (label, fields, text or bytes, expect)."""
    import copy

    names = sorted(scenes)
    for _ in range(n):
        name = rng.choice(names)
        data = copy.deepcopy(scenes[name])
        leaves = list(_leaves(data))
        path, old = rng.choice(leaves)
        key = str(path[-1]) if path else "scene"
        if isinstance(path[-1], int) and len(path) > 1:
            key = str(path[-2])
        kind = rng.choice(["extreme", "extreme", "type", "delete", "unknown", "list", "file"])
        fields = (key, str(path[0]), "scene file", "toml", "utf-8", "nest", "description")
        if kind == "extreme" and (_number_like(old) or (isinstance(old, list) and old
                                                        and _number_like(old[0]))):
            new = rng.choice([*_EXTREMES, NAN, INF, -INF])
            if isinstance(old, list):
                old = list(old)
                old[rng.randrange(len(old))] = new
                new_value = old
            else:
                new_value = new
            _set(data, path, new_value)
            expect = INVALID if isinstance(new, float) and not math.isfinite(new) else EITHER
            yield f"{name}: {'.'.join(map(str, path))} = {new!r}", fields, dump_toml(data), expect
        elif kind in ("type", "extreme") or (kind == "list" and not isinstance(old, list)):
            new = rng.choice(_TYPES)
            same = type(new) is type(old) or (key == "max_force" and new == [1.0])
            if isinstance(old, list) and new == [1.0]:
                same = False
            _set(data, path, new)
            expect = EITHER if same else INVALID
            if key in ("sources",) and isinstance(new, list):
                expect = EITHER
            yield f"{name}: {'.'.join(map(str, path))} = {new!r}", fields, dump_toml(data), expect
        elif kind == "delete":
            _set(data, path, _DELETE)
            # any named error will do: the message names what is now missing
            yield f"{name}: del {'.'.join(map(str, path))}", ("",), dump_toml(data), EITHER
        elif kind == "unknown":
            table = rng.choice([k for k, v in data.items() if isinstance(v, dict)] + [None])
            target = data if table is None else data[table]
            target["bogus_field"] = 1.0
            yield (f"{name}: unknown key in [{table}]", ("bogus_field", "unknown"),
                   dump_toml(data), INVALID)
        elif kind == "list" and old:
            new = old[:-1] if rng.random() < 0.5 else [*old, old[-1]]
            _set(data, path, new)
            yield f"{name}: {'.'.join(map(str, path))} resized", fields, dump_toml(data), EITHER
        else:
            data.pop("description", None)
            text = dump_toml(data).encode()
            choice = rng.randrange(4)
            if choice == 0:
                cut = rng.randrange(len(text))
                text = text[:cut] + b"\xff\xfe\x80" + text[cut:]
                yield f"{name}: non-UTF-8 bytes", fields, text, INVALID
            elif choice == 1:
                depth = rng.choice([100, 1000, 5000, 50_000])
                text = b"description = " + b"[" * depth + b"]" * depth + b"\n" + text
                yield f"{name}: nesting depth {depth}", fields, text, INVALID
            elif choice == 2:
                cut = rng.randrange(len(text))
                # any named error will do: the missing part may be any field
                yield f"{name}: truncated at byte {cut}", ("",), text[:cut], EITHER
            else:
                big = rng.choice([1_000, 10_000_000, 10**18])
                data.setdefault("physics", {})["substeps"] = big
                yield f"{name}: substeps = {big}", ("substeps",), dump_toml(data), (
                    EITHER if big <= 1000 else INVALID)


DISTURBANCE_TABLES = {
    "residual_dipole": {"moment_B_Am2": [0.01, -0.02, 0.03]},
    "drag": {"area_m2": 0.06, "cd": 2.2, "cp_offset_B_m": [0.0, 0.0, 0.02],
             "density_scale": 1.0},
    "srp": {"area_m2": 0.06, "reflectivity": 0.3, "cp_offset_B_m": [0.0, 0.01, 0.0],
            "epoch": "2025-03-20T12:00:00"},
}


def toml_probes(n: int, seed: int, tmp: Path, names: list[str]):
    import rbenv

    tomllib = __import__("tomllib") if sys.version_info >= (3, 11) else __import__("tomli")
    from importlib import resources

    folder = resources.files("rbenv") / "scenes"
    scenes = {}
    for name in names:
        scenes[name] = tomllib.loads((folder / f"{name}.toml").read_text())
    if "cubesat-6u-rw" in scenes:  # the orbit's opt-in disturbance tables, mutated too
        import copy

        variant = copy.deepcopy(scenes["cubesat-6u-rw"])
        variant["orbit"].update(DISTURBANCE_TABLES)
        scenes["cubesat-6u-rw+disturbances"] = variant
    rng = random.Random(seed)
    probes = []
    for i, (label, fields, text, expect) in enumerate(toml_mutations(scenes, n, rng)):
        path = tmp / f"mut{i}.toml"
        path.write_bytes(text if isinstance(text, bytes) else text.encode())

        def fn(p=path):
            scene = rbenv.load_scene(p)
            return _episode(scene=scene, steps=5, action=FULL)  # any actuator set

        probes.append(("mutated scene TOML", label, fields, label, expect, fn))
    return probes


# --------------------------------------------------------------------------- main


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("fuzz.json"),
                        help="JSON file to write (default: ./fuzz.json)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--toml", type=int, default=1500, help="mutated TOML probes")
    parser.add_argument("--scenes", default="boom-sat,cubesat-12u,microsat-100kg",
                        help="shipped scenes to mutate (fixed, so runs on old checkouts compare)")
    parser.add_argument("--timeout", type=float, default=5.0, help="seconds per probe")
    parser.add_argument("--memory-gb", type=float, default=4.0, help="address-space cap")
    parser.add_argument("--budget", type=float, default=900.0, help="total seconds, at most")
    parser.add_argument("--rows", nargs="+", choices=ROWS, default=list(ROWS), metavar="ROW",
                        help=f"probe groups to run (default: all of {', '.join(ROWS)})")
    parser.add_argument("--all-probes", action="store_true",
                        help="list every probe in the JSON, not only the findings (a class "
                             f"other than {' or '.join(ANSWERS)}); the counts cover all")
    args = parser.parse_args(argv)

    cap = int(args.memory_gb * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    import rbenv
    from rbenv import core

    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        groups = [("core API", lambda: core_probes(tmp)), ("env options", env_probes),
                  ("env at numerical extremes", extreme_probes),
                  ("mutated scene TOML",
                   lambda: toml_probes(args.toml, args.seed, tmp, args.scenes.split(","))),
                  ("torch backend options", torch_probes)]
        groups = [(row, build) for row, build in groups if row in args.rows]
        counts = {row: dict.fromkeys(COLUMNS, 0) for row in args.rows}
        records = []
        skipped = 0
        for _, build in groups:
            for row, target, fields, value, expect, fn in build():
                if time.perf_counter() - t_start > args.budget:
                    skipped += 1
                    continue
                column, detail = run_probe(fn, expect, fields, args.timeout)
                counts[row][column] += 1
                if args.all_probes or column not in ANSWERS:
                    records.append({"row": row, "target": target, "value": _short(value),
                                    "expect": expect, "class": column, "detail": detail})
    for row in counts:
        counts[row] = {"tried": sum(counts[row].values()), **counts[row]}
    result = {
        "command": " ".join([Path(sys.argv[0]).name, *(argv or sys.argv[1:])]),
        "core": str(Path(core.__file__).parent), "rbenv": str(Path(rbenv.__file__).parent),
        "seed": args.seed, "timeout_s": args.timeout, "wall_s": time.perf_counter() - t_start,
        "skipped_over_budget": skipped, "rows": counts,
        "probes": records,  # every probe with --all-probes, else the findings alone
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1))
    print(table(counts))
    return result


def _short(value) -> str:
    try:
        text = repr(value)
    except Exception:
        text = f"<{type(value).__name__}>"
    return text if len(text) <= 80 else text[:77] + "..."


def table(counts: dict) -> str:
    head = "| probe | tried | " + " | ".join(COLUMNS) + " |"
    lines = [head, "|" + "---|" * (len(COLUMNS) + 2)]
    for row, c in counts.items():
        lines.append(f"| {row} | {c['tried']} | " + " | ".join(str(c[k]) for k in COLUMNS) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
