"""The compiled form of each Robot and the single-state scratch: the Data of a Model/Data split.

A :class:`mrnea.Robot` is plain immutable data (model.py imports no kernel). What the kernels read
(the compiled model and actuator arrays, kernels/layout.py) is made here once per Robot and kept
in :data:`BY_ID`, keyed by ``id(robot)``; the entry is dropped when the Robot is collected
(``weakref.finalize``), before its id can be reused. The scratch of the single-state entries is
one per n: the entries hold the GIL and write every slot before they read it (docs/design.md),
so one scratch serves every Robot of n joints and every Python thread. A Robot sent to another
process is compiled there on its first call.

The fast path of :mod:`mrnea.dynamics` reads ``BY_ID[id(robot)]`` itself (a KeyError sends the
call to the validated path, which calls :func:`of`); its fifth item, whether the Robot is a tree,
picks the entries compiled for a tree's model type (kernels/layout.py: a chain's and a tree's
model arrays differ in type, so that each compiles only its own copies of the passes).
"""

from __future__ import annotations

import weakref

import numpy as np

from mrnea.kernels.layout import TREE, compile_actuators, compile_model, entry_scratch
from mrnea.model import Robot

# BY_ID[id(robot)] = (model, shape, scratch, act, tree): the compiled model (n + 1, NCOL) and
# actuator array (n, NACT), both read-only (kernels/layout.py), the shape (n,) of one state, the
# single-state entries' scratch (one per n) and whether the model is a tree's. A plain tuple: the
# fast path unpacks it, and CPython unpacks an exact tuple faster than a named one (about 25 ns,
# measured).
BY_ID: dict[int, tuple[np.ndarray, tuple[int], tuple[np.ndarray, ...], np.ndarray, bool]] = {}
_SCRATCH: dict[int, tuple[np.ndarray, ...]] = {}


def of(robot: Robot) -> tuple[np.ndarray, tuple[int], tuple[np.ndarray, ...], np.ndarray]:
    """``(model, shape, scratch, act)`` of a (validated) Robot (:data:`BY_ID`'s first four), made
    on its first call."""
    try:
        return BY_ID[id(robot)][:4]
    except KeyError:
        pass
    n = robot.n
    ws = _SCRATCH.get(n) or _SCRATCH.setdefault(n, entry_scratch(n))
    model = compile_model(robot)
    new = (model, (n,), ws, compile_actuators(robot), bool(model[0, TREE]))
    key = id(robot)
    kept = BY_ID.setdefault(key, new)  # another thread may have been first: keep one
    if kept is new:
        weakref.finalize(robot, BY_ID.pop, key, None).atexit = False
    return kept[:4]
