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

The compile notice. Numba compiles each kernel on its first call and caches it on disk; on an
empty cache a library call can take seconds to a minute. The first time in a process that Numba
starts compiling one of mrnea's kernels, the library says so once: a WARNING record
:data:`COMPILE_NOTICE` on the logger ``"mrnea"``, which Python prints as one line on stderr
when logging is not configured. A warm run (every kernel loaded from the cache) says nothing:
Numba raises its ``numba:compile`` event only when it really compiles. Off:
``logging.getLogger("mrnea").setLevel(logging.ERROR)``, or the environment variable
``MRNEA_COMPILE_NOTICE=0`` (the ``mrnea`` command sets it for itself and the processes it
starts: it says so in its own words, mrnea/cli/base.py). A user's own Numba functions raise no
notice. Logging, not :mod:`warnings`: a notice is no warning about the caller's code, and a
warnings filter set to "error" would raise inside Numba's compiler.
The library never starts the command's compile-ahead process (mrnea/cli/ahead.py) by itself: a
library call that starts another Python process would surprise its caller (its CPU, its
memory, a child under a Dask worker or a test runner). To fill the cache before a program's
first call, run ``mrnea check`` once on a robot with as many joints, or call the functions once.
While Numba compiles one of mrnea's kernels, Python's garbage collector runs less often
(:class:`_CompileCollections`); its thresholds are the caller's again when the compile ends.
"""

from __future__ import annotations

import gc
import logging
import os
import weakref

import numpy as np
from numba.core import event

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


#: What the library says, once per process, when Numba starts compiling one of its kernels.
COMPILE_NOTICE = ("mrnea: compiling its kernels (first run only, up to a minute; cached "
                  "afterwards)...")
_LOG = logging.getLogger("mrnea")


def _ours(ev: event.Event) -> bool:
    """Whether a ``numba:compile`` event is one of mrnea's kernels (not the caller's own Numba
    function)."""
    func = getattr((ev.data or {}).get("dispatcher"), "py_func", None)
    return getattr(func, "__module__", "").startswith("mrnea.")


class _CompileNotice(event.Listener):
    """Logs :data:`COMPILE_NOTICE` when Numba starts compiling a kernel of mrnea's, once per
    process (module docstring)."""

    shown = False

    def on_start(self, ev: event.Event) -> None:
        if _CompileNotice.shown or not _ours(ev):
            return
        _CompileNotice.shown = True
        if os.environ.get("MRNEA_COMPILE_NOTICE") != "0":
            _LOG.warning(COMPILE_NOTICE)

    def on_end(self, ev: event.Event) -> None:
        pass


#: Python's cyclic garbage collector's thresholds (:func:`gc.set_threshold`) while Numba
#: compiles one of mrnea's kernels (:class:`_CompileCollections`).
COMPILE_GC_THRESHOLD = (10_000, 10, 10)


class _CompileCollections(event.Listener):
    """While Numba compiles one of mrnea's kernels (from the outermost compile's start to its
    end), the cyclic garbage collector runs less often: :data:`COMPILE_GC_THRESHOLD` instead of
    the caller's thresholds, which are restored at the end (an error included). Numba's compiler
    allocates millions of short-lived objects; at Python's default thresholds (700, 10, 10) the
    collector ran about 2,400 times in a fresh ``mrnea demo`` compiling alone, each full
    collection walking every object of NumPy's, Numba's and matplotlib's modules: 2.1-2.3 s of
    its 20-21 s. With these 660 times, 0.8-1.0 s, at the same peak memory (docs/performance.md
    section 7). Numba compiles under one lock, so the compiles of a process never overlap."""

    depth = 0
    saved: tuple[int, ...] | None = None

    def on_start(self, ev: event.Event) -> None:
        self.depth += 1
        if self.depth == 1 and _ours(ev):
            self.saved = gc.get_threshold()
            gc.set_threshold(*COMPILE_GC_THRESHOLD)

    def on_end(self, ev: event.Event) -> None:
        self.depth -= 1
        if self.depth == 0 and self.saved is not None:
            gc.set_threshold(*self.saved)
            self.saved = None


event.register("numba:compile", _CompileNotice())
event.register("numba:compile", _CompileCollections())


def cold_cache() -> bool:
    """True when the simulation loop has no entry in Numba's disk cache yet (a first run on
    this cache: no cache index of ``simulate_cycles``): the compile-ahead process of the
    commands (mrnea/cli/ahead.py) and a sweep's order of warming its workers
    (mrnea/sweep/engine.py) ask. False with the JIT off, or where Numba's cache layout is not
    the one known (do not guess)."""
    from numba.core.config import DISABLE_JIT

    from mrnea.kernels.simulate import simulate_cycles

    if DISABLE_JIT:
        return False
    try:
        index = simulate_cycles._cache._cache_file._index_path  # Numba's cache layout
    except AttributeError:  # another Numba version
        return False
    return not os.path.exists(index)
