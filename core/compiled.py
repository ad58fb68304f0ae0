"""Optional compiled path (extra ``rbenv[fast]``: numba): the float-path kernels, compiled.

The one-body step runs :mod:`rbenv.core.integrators` and :mod:`rbenv.core.kernels` on Python floats.
This module compiles *those same functions* with numba and loops them over a batch in machine code;
it restates no formula. Three registrations make that possible:

* every function of :mod:`rbenv.core.kernels`, :mod:`rbenv.core.integrators` and
  :mod:`rbenv.core.splitting` is declared to numba as compiling as it is (``overload``
  returning the function itself);
* :func:`rbenv.core.backend.namespace` of a float returns, in compiled code, a namespace whose
  ``sqrt``/``sin``/``cos``/``tan`` are :mod:`math`'s (a third backend, next to FLOAT and NUMPY);
* a :class:`~rbenv.core.body.RigidBody` becomes a numba type whose fields are compile-time constants
  and whose methods *are* RigidBody's ``inertia_times`` and ``inverse_times`` (its ``kind``
  branches fold away; each distinct body compiles its own loop).

Integrators with Python-level control over a batch (``midpoint``'s Newton with continuation on
the unconverged entries, ``splitting``'s per-body frame cache) are not compiled: ``get`` refuses
them by name. The NumPy path stays the default; results agree with it to round-off and with the
float path bit for bit (tests/core/test_compiled.py). The first call of each integrator pays the
JIT compilation (seconds; ``benchmarks.speed`` reports it).

Use: ``rbenv.core.compiled.get("rk4").advance(body, q, w, h, tau_B, tau_W)`` on component tuples of
(N,) arrays, or of floats for one body, exactly like ``rbenv.core.INTEGRATORS["rk4"].advance``.
"""

from __future__ import annotations

import functools
import inspect
import math
import weakref
from dataclasses import dataclass, field

import numpy as np
from rbenv.core import backend, integrators, kernels, splitting
from rbenv.core.body import RigidBody
from rbenv.core.errors import InvalidParameterError

try:
    import numba
    from numba import types
    from numba.extending import (
        NativeValue,
        intrinsic,
        models,
        overload,
        overload_attribute,
        overload_method,
        register_model,
        typeof_impl,
        unbox,
    )
except ImportError:  # the pure-NumPy install
    numba = None

__all__ = ["COMPILED", "available", "get"]

COMPILED = ("euler_seed", "euler", "semi_implicit", "rk4")


def available() -> bool:
    """True when numba is installed (``pip install rbenv[fast]``)."""
    return numba is not None


def _register_math_namespace():
    class MathNamespaceType(types.Type):
        def __init__(self):
            super().__init__(name="MathNamespace")

    math_namespace = MathNamespaceType()
    register_model(MathNamespaceType)(models.OpaqueModel)

    @intrinsic
    def _math_namespace(typingctx):
        def codegen(context, builder, sig, args):
            return context.get_dummy_value()

        return math_namespace(), codegen

    @overload(backend.namespace)
    def _namespace(x):
        return lambda x: _math_namespace()

    def method(fn):
        def typer(ns, x):
            return lambda ns, x: fn(x)

        return typer

    for name in ("sqrt", "sin", "cos", "tan"):
        overload_method(MathNamespaceType, name)(method(getattr(math, name)))


def _register_functions():
    for module in (kernels, integrators, splitting):
        for fn in vars(module).values():
            if inspect.isfunction(fn) and fn.__module__ == module.__name__:
                # The typing function carries fn's own signature (defaults included).
                overload(fn)(functools.wraps(fn)(lambda *a, fn=fn, **kw: fn))

    @overload(_at)
    def _at_typer(c, n):
        if isinstance(c, types.NoneType):
            return lambda c, n: None
        if len(c) == 3:
            return lambda c, n: (c[0][n], c[1][n], c[2][n])
        return lambda c, n: (c[0][n], c[1][n], c[2][n], c[3][n])


def _at(c, n):
    """Entry n of a component tuple (None stays None)."""
    return None if c is None else tuple(x[n] for x in c)


class _FrozenBody:
    """What the compiled code sees of a RigidBody: its fields, frozen into the numba type."""

    def __init__(self, body: RigidBody):
        self.fields = tuple(getattr(body, f) for f in _BODY_FIELDS)


_BODY_FIELDS = ("kind", "is_isotropic", "_diag", "_diag_inv", "_rows", "_inv_rows",
                "inverse_columns")


def _register_body():
    """A numba type per body whose fields are compile-time constants.

    RigidBody's methods branch on ``kind``; as a constant the branch folds away, and a body
    costs no memory traffic in the loop. Each distinct body compiles its own loop.
    """

    class BodyType(types.Type):
        def __init__(self, fields):
            self.fields = fields
            super().__init__(name=f"RigidBody{fields}")

        @property
        def key(self):
            return self.fields

    register_model(BodyType)(models.OpaqueModel)
    typeof_impl.register(_FrozenBody)(lambda val, c: BodyType(val.fields))

    @unbox(BodyType)
    def _unbox(typ, obj, c):
        return NativeValue(c.context.get_dummy_value())

    def constant(i):
        def typer(self):
            value = self.fields[i]
            return lambda self: value

        return typer

    for i, name in enumerate(_BODY_FIELDS):
        overload_attribute(BodyType, name)(constant(i))
    for name in ("inertia_times", "inverse_times"):
        fn = getattr(RigidBody, name)
        overload_method(BodyType, name)(functools.wraps(fn)(lambda *a, fn=fn: fn))


@functools.cache
def _setup():
    _register_math_namespace()
    _register_functions()
    _register_body()


_BODIES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _compiled_body(body: RigidBody) -> _FrozenBody:
    frozen = _BODIES.get(body)
    if frozen is None:
        frozen = _BODIES[body] = _FrozenBody(body)
    return frozen


def _make_loop(kernel):
    @numba.njit
    def loop(body, q, w, h, tau_B, tau_W):
        n_bodies = q[0].shape[0]
        q0, q1, q2, q3 = (np.empty(n_bodies), np.empty(n_bodies), np.empty(n_bodies),
                          np.empty(n_bodies))
        w0, w1, w2 = np.empty(n_bodies), np.empty(n_bodies), np.empty(n_bodies)
        for n in range(n_bodies):
            # no internal momentum, no state-dependent torque: compiled rigid bodies only
            qn, wn = kernel(body, _at(q, n), _at(w, n), h, _at(tau_B, n), _at(tau_W, n), None,
                            None, None)
            q0[n], q1[n], q2[n], q3[n] = qn
            w0[n], w1[n], w2[n] = wn
        return (q0, q1, q2, q3), (w0, w1, w2)

    return loop


_FLOAT64 = np.dtype(np.float64)


def _array(c, n: int) -> np.ndarray:
    # The cheapest test of "(n,) contiguous float64" (c.flags costs a microsecond).
    if type(c) is np.ndarray and c.dtype is _FLOAT64 and c.shape == (n,) and c.strides == (8,):
        return c
    return np.ascontiguousarray(np.broadcast_to(np.asarray(c, dtype=np.float64), (n,)))


def _arrays(components, n: int):
    """(N,) float64 contiguous arrays (as they are when they already are; floats broadcast)."""
    return None if components is None else tuple(_array(c, n) for c in components)


@dataclass(frozen=True)
class CompiledIntegrator:
    """A compiled integrator: ``advance`` has the interface of ``rbenv.core.INTEGRATORS[name]``.

    loop: the batch loop (components are (N,) arrays). kernel: the float kernel itself,
    compiled for one body whose components are floats (the single env's state).
    """

    name: str
    loop: object
    kernel: object
    # (function, frozen body, has τ_B, has τ_W) → its compiled entry point for that signature
    _entries: dict = field(default_factory=dict, repr=False, compare=False)

    def advance(self, body, q, w, h, tau_B=None, tau_W=None):
        """One step of every body: components are (N,) arrays (floats broadcast), or all
        floats for one body (then the result is tuples of floats, as from the float path)."""
        if isinstance(q[0], float):
            try:
                return self.advance_one(body, q, w, h, tau_B, tau_W)
            except TypeError:  # arrays among the floats: broadcast them below
                pass
        n = max(getattr(c, "size", 1) for c in (*q, *w))  # a float has no size: 1
        frozen = _compiled_body(body)
        return self._entry(self.loop, frozen, tau_B, tau_W)(
            frozen, _arrays(q, n), _arrays(w, n), float(h), _arrays(tau_B, n),
            _arrays(tau_W, n))

    def advance_one(self, body, q, w, h, tau_B=None, tau_W=None):
        """One body, components as floats: the compiled float kernel itself."""
        frozen = _compiled_body(body)
        args = (frozen, tuple(q), tuple(w), float(h), None if tau_B is None else tuple(tau_B),
                None if tau_W is None else tuple(tau_W))
        return self._entry(self.kernel, frozen, tau_B, tau_W)(*args, None, None, None)

    def _entry(self, function, frozen, tau_B, tau_W):
        """``function`` compiled for this body and these torque arguments, as its entry point:
        numba's per-call type dispatch (about 20–50 µs for these argument types) is paid once
        per signature instead of per call."""
        key = (function, frozen, tau_B is None, tau_W is None)
        entry = self._entries.get(key)
        if entry is None:
            item = types.float64 if function is self.kernel else types.Array(types.float64, 1,
                                                                              "C")
            vec = types.UniTuple(item, 3)
            sig = [numba.typeof(frozen), types.UniTuple(item, 4), vec, types.float64,
                   types.none if tau_B is None else vec, types.none if tau_W is None else vec]
            if function is self.kernel:  # momentum_B, momentum_rate_B, torque_fn: none
                sig += [types.none, types.none, types.none]
            entry = self._entries[key] = function.compile(tuple(sig))
        return entry


@functools.cache
def get(name: str) -> CompiledIntegrator:
    """The compiled integrator ``name`` (one of COMPILED); compiled on its first call."""
    if numba is None:
        raise InvalidParameterError(
            "the compiled path needs numba: install the extra with pip install 'rbenv[fast]'")
    if name not in COMPILED:
        raise InvalidParameterError(f"compiled integrator must be one of {list(COMPILED)}, "
                                    f"got {name!r}")
    _setup()
    kernel = integrators.INTEGRATORS[name].advance
    return CompiledIntegrator(name, _make_loop(kernel), numba.njit(kernel))
