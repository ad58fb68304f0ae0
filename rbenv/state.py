"""Episode state shared by plant and task, for one satellite (floats) or N (arrays).

A state is one plain object with a field per quantity. Each field has a *kind* that says how it
is stored; an episode start (see :func:`rbenv.transition.start`) gives each field's value in
the same form, for the envs being reset (m of them):

=========  ============================  ===========================  ======================
kind       one satellite                 N satellites                 start value
=========  ============================  ===========================  ======================
``"c3"``   tuple of 3 floats             tuple of 3 (N,) arrays       3 floats or (m,) arrays
``"c4"``   tuple of 4 floats             tuple of 4 (N,) arrays       4 floats or (m,) arrays
``"f"``    float                         (N,) float array             a float or (m,)
``"i"``    int                           (N,) int64 array             a number or (m,)
``"row"``  (n,) array                    (N, n) array                 (m, n) array
``"obj"``  ``value.single()``            value, rows set by assign()  an EpisodeModel
=========  ============================  ===========================  ======================

A start value of None leaves the field None (the model is off). The single env builds its state
with :func:`from_start`; the vector env with :func:`from_start` at a full reset and
:func:`assign` for the sub-envs that autoreset.
"""

from __future__ import annotations

import numpy as np

__all__ = ["State", "assign", "from_start"]


class State:
    """Mutable episode state: attributes named by the plant's and the task's field tables."""

    def __repr__(self):
        return f"State({', '.join(sorted(vars(self)))})"


def _single(kind: str, value):
    if kind in ("c3", "c4"):
        return tuple(float(c) for c in value)
    if kind == "f":
        return float(value)
    if kind == "i":
        return int(value)
    if kind == "row":
        return np.array(value[0], dtype=float)
    return value.single()


def _batch(kind: str, value):
    if kind in ("c3", "c4"):
        return tuple(np.array(c, dtype=float) for c in value)
    if kind == "f":
        return np.array(value, dtype=float)
    if kind == "i":
        return np.array(value, dtype=np.int64)
    if kind == "row":
        return np.array(value, dtype=float)
    return value


def from_start(kinds: dict, start: dict, single: bool) -> State:
    """A new state from ``start`` (name → start value), one satellite or a batch."""
    st = State()
    convert = _single if single else _batch
    for name, kind in kinds.items():
        value = start.get(name)
        setattr(st, name, None if value is None else convert(kind, value))
    return st


def assign(st: State, kinds: dict, idx: np.ndarray, start: dict) -> None:
    """Write ``start`` (values for the len(idx) envs in ``idx``) into rows ``idx`` of ``st``."""
    for name, kind in kinds.items():
        value, field = start.get(name), getattr(st, name)
        if value is None or field is None:
            continue
        if kind in ("c3", "c4"):
            for comp, new in zip(field, value, strict=True):
                comp[idx] = new
        elif kind == "obj":
            field.assign(idx, value)
        else:
            field[idx] = value
