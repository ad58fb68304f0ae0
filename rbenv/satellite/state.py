"""Episode state for one satellite (floats) or N (arrays): typed fields, each owned by one part.

The plant, each of its actuators and the task declare their own fields, name → *kind*; a
:class:`Layout` collects the declarations and refuses a name that two parts declare, naming
both owners, so no part can overwrite another's field by accident. A kind says how a field is
stored; an episode start (see :func:`rbenv.envs.transition.start`) gives each field's value in the
same form, for the envs being reset (m of them):

=========  ============================  ===========================  ======================
kind       one satellite                 N satellites                 start value
=========  ============================  ===========================  ======================
``"c3"``   tuple of 3 floats             tuple of 3 (N,) arrays       3 floats or (m,) arrays
``"c4"``   tuple of 4 floats             tuple of 4 (N,) arrays       4 floats or (m,) arrays
``"cn"``   tuple of n floats             tuple of n (N,) arrays       n floats or (m,) arrays
``"f"``    float                         (N,) float array             a float or (m,)
``"i"``    int                           (N,) int64 array             a number or (m,)
``"row"``  (n,) array                    (N, n) array                 (m, n) array
``"obj"``  ``value.single()``            value, rows set by assign()  an EpisodeModel
=========  ============================  ===========================  ======================

A start value of None leaves the field None (the model is off). The single env builds its state
with :func:`from_start`; the vector env with :func:`from_start` at a full reset and
:func:`assign` for the sub-envs that autoreset.

The transition never changes a state it is given: :meth:`State.copy` makes the new state, and
each part sets its own fields on the copy (rebinding them: no field is written in place). Only
the vector env's autoreset writes rows in place (:func:`assign`), into the state it owns.
"""

from __future__ import annotations

import numpy as np

from rbenv.core.errors import InvalidParameterError

__all__ = ["KINDS", "Layout", "State", "assign", "from_start"]

KINDS = ("c3", "c4", "cn", "f", "i", "row", "obj")
_COMPONENTS = ("c3", "c4", "cn")


class State:
    """Episode state: one attribute per declared field (see :class:`Layout`)."""

    def copy(self) -> State:
        """A new state holding the same field values (a shallow copy: values are rebound,
        never written in place, by the transition)."""
        new = object.__new__(State)
        new.__dict__.update(self.__dict__)
        return new

    def __repr__(self):
        return f"State({', '.join(sorted(vars(self)))})"


class Layout:
    """The state fields of every part: name → kind, and name → owner.

    parts: (owner name, {field: kind}) pairs, e.g. ("plant", PLANT_FIELDS). A field declared by
    two owners, or with an unknown kind, raises :class:`InvalidParameterError` naming it.
    """

    __slots__ = ("kinds", "owners")

    def __init__(self, parts):
        self.kinds: dict = {}
        self.owners: dict = {}
        for owner, fields in parts:
            for name, kind in fields.items():
                if kind not in KINDS:
                    raise InvalidParameterError(
                        f"{owner} state field {name!r} has kind {kind!r}; kinds are {KINDS}")
                if name in self.owners:
                    raise InvalidParameterError(
                        f"state field {name!r} is declared by both {self.owners[name]} and "
                        f"{owner}; each field must have one owner (rename one of them)")
                self.kinds[name] = kind
                self.owners[name] = owner

    def fields_of(self, owner: str) -> tuple:
        """The names of the fields that ``owner`` declared."""
        return tuple(n for n, o in self.owners.items() if o == owner)


def _single(kind: str, value):
    if kind in _COMPONENTS:
        return tuple(float(c) for c in value)
    if kind == "f":
        return float(value)
    if kind == "i":
        return int(value)
    if kind == "row":
        return np.array(value[0], dtype=float)
    return value.single()


def _batch(kind: str, value):
    if kind in _COMPONENTS:
        return tuple(np.array(c, dtype=float) for c in value)
    if kind == "f":
        return np.array(value, dtype=float)
    if kind == "i":
        return np.array(value, dtype=np.int64)
    if kind == "row":
        return np.array(value, dtype=float)
    return value


def from_start(layout: Layout, start: dict, single: bool) -> State:
    """A new state from ``start`` (name → start value), one satellite or a batch."""
    st = State()
    convert = _single if single else _batch
    for name, kind in layout.kinds.items():
        value = start.get(name)
        setattr(st, name, None if value is None else convert(kind, value))
    return st


def assign(st: State, layout: Layout, idx: np.ndarray, start: dict) -> None:
    """Write ``start`` (values for the len(idx) envs in ``idx``) into rows ``idx`` of ``st``.

    The vector env's autoreset: it owns ``st`` and reuses its buffers (no new state per step).
    """
    for name, kind in layout.kinds.items():
        value, field = start.get(name), getattr(st, name)
        if value is None or field is None:
            continue
        if kind in _COMPONENTS:
            for comp, new in zip(field, value, strict=True):
                comp[idx] = new
        elif kind == "obj":
            field.assign(idx, value)
        else:
            field[idx] = value
