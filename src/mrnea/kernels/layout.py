"""The compiled layout, in one place: what the kernels read (the model and actuator arrays), the
scratch they write (named slots), the Numba options they are compiled with and the types of the
single-state entries. The status codes are in ``status.py`` (no Numba there).

Compiled model (:func:`compile_model`): one read-only float64 array of shape ``(n + 1, NCOL)``.
Row 0 holds the gravity vector in ``[0:3]`` and, in ``[TREE]``, 1 for a tree (some λ(i) < i - 1),
0 for a serial chain; row ``i + 1`` describes joint ``i`` and link ``i``::

    TYPE        0 revolute (and continuous), 1 prismatic (kernels ask :func:`is_prismatic`)
    ROT  (9)    origin rotation A, parent link frame -> joint frame, row-major
    POS  (3)    origin translation [m], parent link frame
    AXIS (3)    unit joint axis a, joint frame
    MASS        link mass [kg]
    COM  (3)    centre of mass [m], link frame
    INER (9)    inertia about the centre of mass [kg m^2], link-frame axes, row-major
    ROTB (9)    A [a]x     precomputed so that the link's rotation relative to its parent,
    ROTC (9)    A [a]x^2   A Rot(a, q) = A + sin(q) A [a]x + (1 - cos(q)) A [a]x^2 (Rodrigues)
    ZAX  (3)    A a, the joint axis in the parent link frame
    NOPOS       1 for a revolute joint whose POS is exactly zero: o_i is the parent's origin
    NOCOM       1 where COM is exactly zero: the centre of mass is the link frame's origin
    PARENT      λ(i), the joint whose link carries link i (-1: the base); λ(i) = i - 1 on a chain
    SUBEND      end of the subtree ν(i) = [i, SUBEND): k is an ancestor-or-self of i iff
                k <= i < SUBEND(k) (:func:`carries`)
    BRANCH      1 where link i has two children or more (its forward quantities are kept for
                the later children, its backward sums stashed: docs/notation.md, Trees)
    STASH       for a branch point, the first slot of its stash in ``column_stash`` (a stack,
                laid out here by :func:`tree_columns`); -1 elsewhere
    DEPTH       the number of joints carrying link i (0: hangs from the base); column k of a
                stash is in slot STASH + DEPTH(k)

Joints are in depth-first order from the base (``Robot`` checks it), so λ(i) < i and every
subtree is a contiguous index range; the integer columns are stored as exact floats.

Chain or tree is a compile-time choice, made by the array's TYPE: a serial chain's model is
row-major (C order, :data:`MODEL_T`), a tree's column-major (Fortran order,
:data:`MODEL_TREE_T`); the values, and so every result, are the same. :func:`tree_of` and
:func:`tree_scratch` read the type, so that Numba compiles only a chain's copies of the passes
for a chain (without the tree's branches) and only a tree's for a tree: a program runs one robot,
and its first run compiles one set (docs/performance.md section 18). The tree's copies run any
model, so any layout but C runs correctly; only a C-order copy of a TREE's model (``m.copy()``,
``np.ascontiguousarray(m)``) would run a chain's copies on a tree: copy a model with
``order="K"`` (pickling keeps the order), or make it again with :func:`compile_model`.

NOPOS and NOCOM are the specialisation the paper's Sec. IV makes by hand for the SDT: terms with
a zero offset vanish, and the kernels skip them (``compile_model(robot, specialise=False)``
leaves both flags at 0 and so runs every term: the general path the tests compare with).

Actuator array (:func:`compile_actuators`): read-only float64, ``(n, NACT)``, joint side, row i
for joint i (fields: :data:`mrnea.actuator_fields.ACTUATOR_FIELDS`)::

    GEAR  G     JM  J_m [kg m^2, motor side]     FV  F_v
    FPOS, FNEG  Coulomb friction F+, F- (magnitudes opposing positive, negative motion)
    PEAK, CORNER, NOLOAD   the torque-speed curve (a constant limit: CORNER = NOLOAD = inf)
    LOWER, UPPER, VLIM     position and velocity limits
    ETAD, ETAB  gear efficiency driving, back-driven (kernels/drive.py ``effort_box``)

The kernels that need both take them as one tuple, ``compiled = (model, act)``.

Scratch (:func:`scratch`): the buffers of one state, the tuple ``(T, V, S, I)`` of 3x3 matrices
T (2n, 3, 3), 3-vectors V (10n, 3), rows of n floats S and rows of n ints I. A kernel takes its
buffers through the slot functions below (first-axis slices: no copy, no reshape), never by row
arithmetic of its own; :func:`scratch` is told what the scratch is for (``POSE``, ``SOLVE``,
``ACHIEVABLE``) and allocates the rows those slots need (allocation costs time by the
byte). The slots of kernels that call one another are disjoint; the others share rows, which
holds because every kernel writes a slot before it reads it::

    pose_buffers      R = T[:n], Ic = T[n:2n], o, z, c = V[:3n]  the kinematics pass (and
                                                                   kinematics.py's frames, J)
    mrnea_buffers     e, d, E, M = V[3n:7n]                        the mRNEA pass
    force_buffers     f, nm = V[3n:5n]                             the Newton-Euler passes
    branch_buffers    w, wd, a = V[7n:10n]                         a tree's forward passes
    stash_buffers     Sc, Sn = V[7n:9n]                            a tree's backward passes
    column_stash      S[n:2n]                                      mRNEA's, on a tree
    effort_buffer     S[0]                                         reactions' efforts
    solve_buffers     H, L = S[:2n]; u', rhs = S[2n:2n + 2]         forward dynamics
    achievable_buffers  H_a = S[:n]; S[3n:3n + 6], S[3n + 15]      one cycle's problem
    drive_solve_buffers  S[n:3n], S[3n + 6:3n + 15], I[:4]          its exact solve
    tree_solve_buffers   I[4:6]                                      on a tree's free joints
    update_buffers       S[3n + 16:3n + 18]                          with its factor updated
    loop_buffers         S[3n + 18:3n + 21]                          the simulation loop's
                                                                     next state; qdd_des of
                                                                     the program's requirement

A single-state entry takes the scratch its caller keeps (:func:`entry_scratch`: a ``SOLVE``
scratch, the largest an entry needs); a batch kernel takes a stack of them, one per thread
(:func:`batch_scratch`), and each state its thread's own (:func:`own_scratch`); the simulation
loop takes one per run (an ``ACHIEVABLE`` entry scratch): nothing on the hot path allocates.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numba as nb
import numpy as np
from numba.extending import overload

if TYPE_CHECKING:
    from mrnea.model import Robot

# --- the compiled model ---------------------------------------------------------------------------
TYPE, ROT, POS, AXIS, MASS, COM, INER, ROTB, ROTC, ZAX, NOPOS, NOCOM = (
    0, 1, 10, 13, 16, 17, 20, 29, 38, 47, 50, 51)
PARENT, SUBEND, BRANCH, STASH, DEPTH = 52, 53, 54, 55, 56
TREE = 3  # row 0: 1.0 for a tree
NCOL = 57
PRISMATIC = 1.0

# --- the actuator array ---------------------------------------------------------------------------
GEAR, JM, FV, FPOS, FNEG, PEAK, CORNER, NOLOAD, LOWER, UPPER, VLIM, ETAD, ETAB = range(13)
NACT = 13

# --- Numba options, set in one place: compiled code is cached on disk next to the sources --------
# JIT: a kernel that allocates nothing runs without reference counting ("_nrt": False). Every
# array it sees belongs to a caller that holds it for the whole call, so the atomic
# increments and decrements Numba would emit for each array argument and view (dozens per
# state, contended between threads in a batch) are pure cost. Such a kernel must not return an
# array (its caller would release a reference it never took): the helpers that return views
# are INTO_CALLER, compiled into their caller. No fastmath: NaN and inf checks must stay, and fused
# multiply-adds (4-8 % faster, measured) would round differently from the same sums in NumPy.
# ALLOC: a kernel that allocates (a scratch, or the comparison kernels' own arrays).
JIT = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy", "_nrt": False}
ALLOC = {**JIT, "_nrt": True}
# ENTRY: a single-state kernel the public API calls from Python (dynamics._Entry), on the scratch
# its caller keeps (``entry_scratch``, one per n: mrnea.compiled). It keeps the GIL: that is what
# makes one scratch safe to share between Python threads, and a call of a few microseconds
# gains nothing from releasing it (releasing and retaking cost about 0.1 us, measured). It
# allocates nothing, so its arguments are unboxed without Numba's runtime (about 40 ns an array
# less). ENTRY_ALLOC: the same for the comparison kernels (ABA, CRBA, Walker-Orin), which
# allocate arrays of their own. Batch and simulation kernels release the GIL.
ENTRY = {**JIT, "nogil": False}
ENTRY_ALLOC = {**ALLOC, "nogil": False}
INLINE = JIT
# PARALLEL: a batch kernel: a prange over the states, each on its thread's scratch from the
# stack its caller makes (``batch_scratch``, ``own_scratch``). It allocates nothing, so it runs
# without Numba's runtime (docs/design.md)
PARALLEL = {**JIT, "parallel": True}
# INTO_CALLER: compiled into the caller's code by Numba itself, whatever runtime the caller has:
# the slot functions (they return views), and solve.solve_forward, whose call of its own made
# forward dynamics 3 % slower (measured; LLVM did not inline it)
INTO_CALLER = {"inline": "always"}

# --- the types of the single-state entries (dynamics._Entry compiles them for exactly these) -----
MODEL_T = nb.types.Array(nb.types.float64, 2, "C", readonly=True)  # a serial chain's model
MODEL_TREE_T = nb.types.Array(nb.types.float64, 2, "F", readonly=True)  # a tree's
IN_T = nb.types.Array(nb.types.float64, 1, "A")  # a state: any layout
OUT1_T = nb.types.Array(nb.types.float64, 1, "C")  # outputs, as the wrappers allocate them
OUT2_T = nb.types.Array(nb.types.float64, 2, "C")
OUT3_T = nb.types.Array(nb.types.float64, 3, "C")
SCRATCH_T = nb.types.Tuple((nb.types.Array(nb.types.float64, 3, "C"), OUT2_T, OUT2_T,
                            nb.types.Array(nb.types.int64, 2, "C")))  # entry_scratch


@nb.njit(**INLINE)
def is_prismatic(model, i):
    """Whether joint i (0-based: row i + 1 of the compiled model) is prismatic."""
    return model[i + 1, TYPE] == PRISMATIC


@nb.njit(**INLINE)
def parent(model, i):
    """λ(i): the joint whose link carries link i (-1: the base)."""
    return int(model[i + 1, PARENT])


@nb.njit(**INLINE)
def carries(model, k, i):
    """Whether link k carries link i or is it (k in κ(i) ∪ {i}), given k <= i: i < SUBEND(k)."""
    return i < model[k + 1, SUBEND]


def tree_columns(parents: tuple[int, ...]) -> np.ndarray:
    """``(n, 5)``: PARENT, SUBEND, BRANCH, STASH and DEPTH (layout above) of a depth-first
    parent array.

    The stashes of a backward pass form a stack: branch point b's opens when its last child is
    done (the pass runs n - 1 -> 0) and closes at b's own step, and every stash opened in
    between belongs to a branch point inside b's subtree, so it closes first. Each holds
    DEPTH(b) + 1 slots (the columns k in κ(b) ∪ {b}) of 6 floats; at most about n^2 / 6 slots
    are open at once (docs/notation.md, Trees), so the stack fits the n x n floats of
    ``column_stash``.
    """
    n = len(parents)
    end = list(range(1, n + 1))
    count = [0] * n  # children
    depth = [0] * n
    for i in range(n):
        if parents[i] >= 0:
            depth[i] = depth[parents[i]] + 1
            count[parents[i]] += 1
    for i in range(n - 1, -1, -1):
        if parents[i] >= 0:
            end[parents[i]] = max(end[parents[i]], end[i])
    stash, top = [-1] * n, 0
    for i in range(n - 1, -1, -1):  # the backward pass's order
        if count[i] > 1:  # b's step closes its stash, the top of the stack
            top = stash[i]
        b = parents[i]
        if b >= 0 and b != i - 1 and end[i] == end[b]:  # b's last child done: b's stash opens
            stash[b] = top
            top += depth[b] + 1
            assert 6 * top <= n * n  # the bound above
    return np.array([[parents[i], end[i], float(count[i] > 1), stash[i], depth[i]]
                     for i in range(n)], dtype=float)


def compile_model(robot: Robot, specialise: bool = True) -> np.ndarray:
    """Flatten a validated Robot into the ``(n + 1, NCOL)`` array described above.

    ``specialise=False`` keeps the NOPOS and NOCOM flags at 0 (every term is computed).
    """
    m = np.zeros((robot.n + 1, NCOL))
    m[0, :3] = robot.gravity
    m[1:, PARENT:DEPTH + 1] = tree_columns(robot.parents)
    m[0, TREE] = float(any(p != i - 1 for i, p in enumerate(robot.parents)))
    for i, (j, lk) in enumerate(zip(robot.joints, robot.links, strict=True), start=1):
        A = j.origin[:3, :3]
        ax = np.asarray(j.axis, dtype=float)
        K = np.array([[0.0, -ax[2], ax[1]], [ax[2], 0.0, -ax[0]], [-ax[1], ax[0], 0.0]])
        m[i, TYPE] = PRISMATIC if j.is_prismatic else 0.0
        m[i, ROT:ROT + 9] = A.ravel()
        m[i, POS:POS + 3] = j.origin[:3, 3]
        m[i, AXIS:AXIS + 3] = ax
        m[i, MASS] = lk.mass
        m[i, COM:COM + 3] = lk.com
        m[i, INER:INER + 9] = lk.inertia.ravel()
        m[i, ROTB:ROTB + 9] = (A @ K).ravel()
        m[i, ROTC:ROTC + 9] = (A @ K @ K).ravel()
        m[i, ZAX:ZAX + 3] = A @ ax
        if specialise:
            m[i, NOPOS] = float(not j.is_prismatic and not np.any(j.origin[:3, 3]))
            m[i, NOCOM] = float(not np.any(lk.com))
    if m[0, TREE]:
        m = np.asfortranarray(m)  # the type that compiles a tree's copies (module docstring)
    m.setflags(write=False)
    return m


def model_type_is_chain(model: nb.types.Type) -> bool:
    """Whether a compiled model's Numba type is a serial chain's (C order: module docstring)."""
    return isinstance(model, nb.types.Array) and model.layout == "C"


def tree_of(model):
    """None for a serial chain's model, True for a tree's, chosen by the model's TYPE (module
    docstring): passed as the ``tree`` argument of ``common.kinematics``, it compiles the chain's
    copy (without the parent look-ups) for a chain only. Python body for NUMBA_DISABLE_JIT;
    compiled code uses the overload."""
    return True if model[0, TREE] else None


def tree_scratch(model, ws):
    """None for a serial chain's model, else the scratch ``ws`` (as :func:`tree_of`): the
    ``ws`` argument of ``rnea.newton_euler`` and ``rnea.link_forces``, None compiling a chain's
    copy. Python body for NUMBA_DISABLE_JIT; compiled code uses the overload."""
    return ws if model[0, TREE] else None


@overload(tree_of, inline="always")
def _tree_of_overload(model):
    if model_type_is_chain(model):
        return lambda model: None
    return lambda model: True


@overload(tree_scratch, inline="always")
def _tree_scratch_overload(model, ws):
    if model_type_is_chain(model):
        return lambda model, ws: None
    return lambda model, ws: ws


def compile_actuators(robot: Robot) -> np.ndarray:
    """The ``(n, NACT)`` actuator array of a validated Robot (layout above)."""
    a = np.empty((robot.n, NACT))
    for i, j in enumerate(robot.joints):
        curve = j.torque_speed or (j.effort_limit, math.inf, math.inf)
        a[i] = (j.gear_ratio, j.rotor_inertia, j.viscous_friction, *j.coulomb_pair,
                *curve, j.lower, j.upper, j.velocity_limit, *j.efficiency_pair)
    a.setflags(write=False)
    return a


# --- the scratch ----------------------------------------------------------------------------------
# what a scratch is for: the kinematics and Newton-Euler or mRNEA passes (and the reactions'
# efforts), those and a forward-dynamics solve, or the achievable accelerations
POSE, SOLVE, ACHIEVABLE = 0, 1, 2
BATCH_PAD = 8  # unused rows after each thread's scratch in a batch stack (``new_scratches``)


@nb.njit(**INTO_CALLER)
def scratch_rows(n, kind):
    """Rows of S and of I a scratch for ``kind`` holds (the slots below)."""
    if kind == ACHIEVABLE:
        return 3 * n + 21, 6
    if kind == SOLVE:
        return 2 * n + 2, 0
    return 1, 0  # POSE: S[0], the reactions' efforts


@nb.njit(**ALLOC)
def new_scratches(n, s_rows, i_rows, count, pad):
    """``count`` scratches with s_rows rows of S and i_rows of I (at least one each), stacked on
    a leading axis: ``(T, V, S, I)`` of shapes (count, 2n + pad, 3, 3), (count, 10n + pad, 3),
    (count, s + pad, n), (count, i + pad, n). The ``pad`` rows at the end of each scratch are
    never used: 8 of them keep the rows two threads write at least a cache line (64 bytes)
    apart, so that the threads of a batch do not take the same cache line from each other
    (false sharing: up to 1.5x the time of a 6-joint batch on two threads, measured)."""
    return (np.empty((count, 2 * n + pad, 3, 3)), np.empty((count, 10 * n + pad, 3)),
            np.empty((count, max(s_rows, 1) + pad, n)),
            np.empty((count, max(i_rows, 1) + pad, n), dtype=np.int64))


@nb.njit(**INTO_CALLER)
def scratch_of(ws, k):
    """Scratch k ``(T, V, S, I)`` of a stack made by ``new_scratches``."""
    return ws[0][k], ws[1][k], ws[2][k], ws[3][k]


@nb.njit(**ALLOC)
def scratch(n, kind):
    """A new scratch ``(T, V, S, I)`` for one state of an n-joint robot, for ``kind``."""
    s_rows, i_rows = scratch_rows(n, kind)
    return scratch_of(new_scratches(n, s_rows, i_rows, 1, 0), 0)


@nb.njit(**INTO_CALLER)
def own_scratch(ws):
    """The calling thread's scratch of a batch kernel's stack (``batch_scratch``): threads
    share no buffer, and taking it allocates nothing. The stack must have been made for the
    thread count the kernel runs on (``numba.get_thread_id()`` below it): by ``batch_scratch``
    in the same call, on the same Python thread, as the launch."""
    return scratch_of(ws, nb.get_thread_id())


def entry_scratch(n: int, kind: int = SOLVE) -> tuple[np.ndarray, ...]:
    """A scratch made in Python by the kernels' own source (so nothing more is compiled); the
    default, ``SOLVE``, serves every single-state entry."""
    return tuple(a[0] for a in _new_scratches(n, kind, 1, 0))


def batch_scratch(n: int, kind: int = SOLVE) -> tuple[np.ndarray, ...]:
    """A batch kernel's scratch: one per thread of the calling thread's
    ``numba.get_num_threads()``, stacked (``new_scratches``), with ``BATCH_PAD`` rows of padding
    between threads. The default kind, ``SOLVE``, is what every single-state entry takes; it
    serves every batch kernel but ``achievable_batch`` (``ACHIEVABLE``). Made in Python: a
    kernel that asks for the thread count is not cached (docs/design.md)."""
    return _new_scratches(n, kind, nb.get_num_threads(), BATCH_PAD)


def _new_scratches(n: int, kind: int, count: int, pad: int) -> tuple[np.ndarray, ...]:
    rows = getattr(scratch_rows, "py_func", scratch_rows)(n, kind)
    return getattr(new_scratches, "py_func", new_scratches)(n, *rows, count, pad)


@nb.njit(**INTO_CALLER)
def pose_buffers(ws, n):
    """R (n, 3, 3), o, z, c (n, 3), Ic (n, 3, 3): the kinematics pass's output slots."""
    T, V = ws[0], ws[1]
    return T[:n], V[:n], V[n:2 * n], V[2 * n:3 * n], T[n:2 * n]


@nb.njit(**INTO_CALLER)
def mrnea_buffers(ws, n):
    """e, d, E, M (n, 3) of the mRNEA pass (kernels/mrnea.py)."""
    V = ws[1]
    return V[3 * n:4 * n], V[4 * n:5 * n], V[5 * n:6 * n], V[6 * n:7 * n]


@nb.njit(**INTO_CALLER)
def force_buffers(ws, n):
    """f, nm (n, 3): the Newton-Euler passes' forces and moments (kernels/rnea.py); the slots
    of mRNEA's e, d."""
    V = ws[1]
    return V[3 * n:4 * n], V[4 * n:5 * n]


@nb.njit(**INTO_CALLER)
def branch_buffers(ws, n):
    """w, wd, a (n, 3): a tree's forward pass keeps there, for each link with a second child,
    its angular velocity, angular acceleration and its joint point's acceleration (the
    later children read them: docs/notation.md, Trees). Unused on a chain."""
    V = ws[1]
    return V[7 * n:8 * n], V[8 * n:9 * n], V[9 * n:10 * n]


@nb.njit(**INTO_CALLER)
def stash_buffers(ws, n):
    """Sc, Sn (n, 3): a tree's backward passes put the later children's force and moment
    aside there, by branch point (the RNEA's f, n; mRNEA's E_c, n'_c: docs/notation.md, Trees).
    Rows of ``branch_buffers``, free once the forward pass is done. Unused on a chain."""
    V = ws[1]
    return V[7 * n:8 * n], V[8 * n:9 * n]


@nb.njit(**INTO_CALLER)
def column_stash(ws, n):
    """(n, n) floats: mRNEA's stash of a tree's later children's columns E_k, M_k, a stack of
    6-float slots laid out by ``tree_columns`` (slot s: floats 6s .. 6s + 5, row-major). The L
    slot of ``solve_buffers`` and the Hs slot of ``drive_solve_buffers``, both written after
    the mRNEA pass; so mRNEA runs on a ``SOLVE`` or ``ACHIEVABLE`` scratch. Unused on a chain."""
    return ws[2][n:2 * n]


@nb.njit(**INTO_CALLER)
def effort_buffer(ws):
    """(n,): the efforts of the Newton-Euler pass under the joint reactions (not returned)."""
    return ws[2][0]


@nb.njit(**INTO_CALLER)
def solve_buffers(ws, n):
    """H (n, n), its Cholesky factor L (n, n), u' (n,) and tau - u' (n,): forward dynamics."""
    S = ws[2]
    return S[:n], S[n:2 * n], S[2 * n], S[2 * n + 1]


@nb.njit(**INTO_CALLER)
def achievable_buffers(ws, n):
    """One cycle's problem (kernels/achievable.py): H_a (n, n) and the (n,) rows u'_a, F+, F-
    (the Coulomb friction the solve resolves), v_des (the velocity wanted), v (the new one),
    rest (zeros: the start velocity of the one-state form) and the magnitude of the lower
    effort limit (kernels/drive.py ``effort_box``; the caller's ``limit`` holds the upper)."""
    S = ws[2]
    return (S[:n], S[3 * n], S[3 * n + 1], S[3 * n + 2], S[3 * n + 3], S[3 * n + 4],
            S[3 * n + 5], S[3 * n + 15])


@nb.njit(**INTO_CALLER)
def drive_solve_buffers(ws, n):
    """The exact cycle solve's buffers (kernels/drive_solve.py): the free joints' block of H_a
    Hs (n, n) (when the factor is updated instead, its row 0 holds qw) and its Cholesky factor
    Lc (n, n); the (n,) float rows rhs, x (the free joints' solution), vstar (their target
    velocity) and tauc (clamped efforts, PAPER); breakpoints bp (2, n) and piece slopes sl
    (3, n); the (n,) int rows pat (pattern), nbp (number of breakpoints), idx (free joints'
    indices) and tabu."""
    S, ints = ws[2], ws[3]
    v0 = 3 * n + 6
    return (S[n:2 * n], S[2 * n:3 * n], S[v0], S[v0 + 1], S[v0 + 2], S[v0 + 3],
            S[v0 + 4:v0 + 6], S[v0 + 6:v0 + 9], ints[0], ints[1], ints[2], ints[3])


@nb.njit(**INTO_CALLER)
def tree_solve_buffers(ws, n):
    """The exact cycle solve on a tree (kernels/drive_solve.py, ``TreeRefactor``): the (n,) int
    rows near (by joint: the position among the free joints of its nearest free
    ancestor-or-self, -1 for none) and lam_F (by position: the free joints' parent array λ_F,
    docs/notation.md)."""
    ints = ws[3]
    return ints[4], ints[5]


@nb.njit(**INTO_CALLER)
def update_buffers(ws, n):
    """The exact cycle solve with H_FF's factor updated (kernels/drive_solve.py, ``Update``):
    the (n,) rows g = H_a qw and |H_a| |qw| (qw: qdd on the held joints, 0 on the free ones),
    kept as joints are held and released."""
    S = ws[2]
    return S[3 * n + 16], S[3 * n + 17]


@nb.njit(**INTO_CALLER)
def loop_buffers(ws, n):
    """The simulation loop's (n,) rows (kernels/simulate.py): the next state q_next, qd_next
    and the velocity v wanted over the next interval; the program's requirement, which runs
    after the loop's cycles, takes the last for its qdd_des."""
    S = ws[2]
    return S[3 * n + 18], S[3 * n + 19], S[3 * n + 20]


@nb.njit(**ALLOC)
def pose_arrays(n):
    """R, o, z, c, Ic in a new scratch (for the comparison kernels, which allocate per call)."""
    return pose_buffers(scratch(n, POSE), n)
