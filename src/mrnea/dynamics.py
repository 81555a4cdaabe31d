"""Rigid-body dynamics, the public NumPy API (paper Eq. 1: no rotor inertia, no friction).

Every function takes one state, arrays of shape ``(n,)``, or a batch, shape ``(B, n)``; arguments
of both kinds broadcast against each other, and a batch runs as one compiled, parallel loop.
Units: q [rad | m], qd [rad/s | m/s], qdd [rad/s^2 | m/s^2], tau [N m | N].

External wrench. ``f_ext = [f_e; n_e]`` (6,) or (B, 6), in base coordinates [N, N m], is the wrench
the last moving link exerts **on its environment** (the paper's k_e): the joints must supply
``J(q)^T f_ext`` on top of the free motion. It acts at the origin of the last link's frame, or at
``f_ext_point`` (3,) or (B, 3) [m], a point given in that link's frame (the paper's p_e). Example:
the tool pushes down on a table with 10 N: ``f_ext = [0, 0, -10, 0, 0, 0]``. (A force the
environment applies *to* the robot, Pinocchio's and MuJoCo's convention, is the negative.)

The caller's arrays are never modified. Errors are :class:`mrnea.errors.StateError` (shapes, NaN,
unknown method) and :class:`mrnea.errors.SingularMassMatrixError`.

The fast path. A single state of one-dimensional float64 ndarrays without a wrench goes straight
to a kernel's compiled ``free`` entry (:class:`_Entry`): at n = 6 the kernel takes about 2 us, so
every check in Python counts. The wrapper checks only what the entry cannot (dtype and ndim:
the entry would read another dtype or ndim wrongly); the kernel checks the lengths (status SIZE)
and finiteness. Anything else (lists, a batch, a wrong length, NaN, a non-Robot, which fails
with AttributeError or the entry's TypeError) takes the validated path, :func:`_evaluate`,
which converts the inputs or names the offending one.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import MrneaError, SingularMassMatrixError, StateError
from mrnea.kernels.aba import aba, aba_batch
from mrnea.kernels.common import NONFINITE, OK, OVERFLOW
from mrnea.kernels.crba import fd_crba, fd_crba_batch
from mrnea.kernels.mrnea import fd_mrnea, fd_mrnea_batch, mrnea, mrnea_batch
from mrnea.kernels.rnea import reactions, reactions_batch, rnea, rnea_batch
from mrnea.kernels.walker_orin import (
    fd_walker_orin,
    fd_walker_orin_batch,
    walker_orin,
    walker_orin_batch,
)
from mrnea.model import Robot

Method = Literal["mrnea", "walker_orin", "crba", "aba"]


class _Entry:
    """A single-state kernel called through its machine-code entries for fixed signatures.

    Numba's dispatcher types every argument on every call to pick the compiled version; at this
    size that costs about a third of a call. The public functions check what the entry cannot
    (the fast path in the module docstring, or :func:`_inputs`), so they call an entry
    directly: ``free`` takes ``fext=None, pe=None`` (no external wrench: Numba compiles that
    case without reading either, and two fewer arrays cross from Python), ``call`` takes both
    arrays.
    ``Dispatcher.compile`` compiles an entry (or loads it from Numba's disk cache) on its first
    call and returns it.
    """

    __slots__ = ("_kernel", "call", "free")

    def __init__(self, kernel: nb.core.registry.CPUDispatcher, *outputs: nb.types.Type) -> None:
        py_func = getattr(kernel, "py_func", kernel)  # a plain function under NUMBA_DISABLE_JIT
        states = [_IN] * (py_func.__code__.co_argcount - 4 - len(outputs))
        self._kernel = kernel
        if hasattr(kernel, "compile"):
            none = nb.types.none
            self.call = self._first(
                "call", nb.types.int64(_MODEL, *states, _IN, _IN, *outputs, _SCRATCH))
            self.free = self._first(
                "free", nb.types.int64(_MODEL, *states, none, none, *outputs, _SCRATCH))
        else:
            self.call = self.free = kernel

    def _first(self, slot: str, sig: nb.core.typing.Signature) -> Callable[..., int]:
        """A stand-in for the entry ``slot`` that compiles it on its first call."""

        def first(*args: object) -> int:
            entry = self._kernel.compile(sig)
            setattr(self, slot, entry)
            return entry(*args)

        return first


# the signatures: the compiled model, inputs of any layout, outputs as allocated here
_MODEL = nb.types.Array(nb.types.float64, 2, "C", readonly=True)
_IN = nb.types.Array(nb.types.float64, 1, "A")
_OUT1 = nb.types.Array(nb.types.float64, 1, "C")
_OUT2 = nb.types.Array(nb.types.float64, 2, "C")
_SCRATCH = nb.types.Tuple((nb.types.Array(nb.types.float64, 3, "C"), _OUT2, _OUT2,
                           nb.types.Array(nb.types.int64, 2, "C")))  # Robot._scratch

_FD = {
    "mrnea": (_Entry(fd_mrnea, _OUT1), fd_mrnea_batch),
    "walker_orin": (_Entry(fd_walker_orin, _OUT1), fd_walker_orin_batch),
    "crba": (_Entry(fd_crba, _OUT1), fd_crba_batch),
    "aba": (_Entry(aba, _OUT1), aba_batch),
}
_HB = {"mrnea": (_Entry(mrnea, _OUT2, _OUT1), mrnea_batch),
       "walker_orin": (_Entry(walker_orin, _OUT2, _OUT1), walker_orin_batch)}
_RNEA = _Entry(rnea, _OUT1)
_REACTIONS = _Entry(reactions, _OUT2)
_F64 = np.dtype(np.float64)
_ND = np.ndarray
_ZERO_WRENCH = np.zeros(6)
_ZERO_POINT = np.zeros(3)


def _array(x: ArrayLike, name: str, width: int) -> NDArray[np.float64]:
    """``x`` as a float64 array of shape (width,) or (B, width), all finite."""
    try:
        a = np.asarray(x)
    except (TypeError, ValueError):
        raise StateError(f"{name}: not a numeric array: {x!r}") from None
    if a.dtype.kind not in "biuf":
        raise StateError(f"{name}: expected real numbers, got an array of {a.dtype}")
    # a C-contiguous, writable float64 array: the kernels are compiled for exactly that
    a = np.require(a, dtype=np.float64, requirements=["C", "W"])
    if a.ndim not in (1, 2) or a.shape[-1] != width or (a.ndim == 2 and a.shape[0] == 0):
        raise StateError(f"{name}: expected shape ({width},) or (B, {width}), got {a.shape}")
    if not np.isfinite(a).all():
        bad = np.argwhere(~np.isfinite(a))[0]
        raise StateError(f"{name}: contains NaN or inf (first at index {tuple(bad.tolist())})")
    return a


def _time_step(dt: object) -> float:
    """dt [s] as a float: a finite number > 0 (a bool is not a time step)."""
    if isinstance(dt, bool):
        raise StateError(f"dt: not a number: {dt!r}")
    try:
        dt = float(dt)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise StateError(f"dt: not a number: {dt!r}") from None
    if not (np.isfinite(dt) and dt > 0):
        raise StateError(f"dt: must be a finite time step > 0 s, got {dt}")
    return dt


def _require_robot(robot: object) -> None:
    if not isinstance(robot, Robot):
        raise StateError(f"robot: expected a mrnea.Robot, got {type(robot).__name__}")


def _inputs(
    robot: Robot,
    states: dict[str, ArrayLike],
    f_ext: ArrayLike | None,
    f_ext_point: ArrayLike | None,
) -> tuple[bool, list[NDArray], NDArray, NDArray]:
    """Validate and broadcast. Returns (batched, states, fext, pe); batched arrays are 2-D."""
    _require_robot(robot)
    n = robot.n
    arrays = [_array(v, k, n) for k, v in states.items()]
    fe = _ZERO_WRENCH if f_ext is None else _array(f_ext, "f_ext", 6)
    pe = _ZERO_POINT if f_ext_point is None else _array(f_ext_point, "f_ext_point", 3)
    all_ = [*arrays, fe, pe]
    if all(a.ndim == 1 for a in all_):
        return False, arrays, fe, pe
    sizes = {a.shape[0] for a in all_ if a.ndim == 2}
    if len(sizes) > 1:
        names = [*states, "f_ext", "f_ext_point"]
        shapes = ", ".join(f"{k} {a.shape}" for k, a in zip(names, all_, strict=True))
        raise StateError(f"batch sizes differ: {shapes}")
    B = sizes.pop()
    out = [a if a.ndim == 2 else np.repeat(a[None], B, axis=0) for a in all_]
    return True, out[:-2], out[-2], out[-1]


def _method(method: str, table: dict) -> tuple:
    """``table[method]``; a StateError for a method the table does not hold."""
    try:
        return table[method]
    except (KeyError, TypeError):  # TypeError: an unhashable value
        raise StateError(
            f"method: unknown {method!r}; expected one of {', '.join(map(repr, table))}"
        ) from None


def _check(robot: Robot, status: int | NDArray, states: dict[str, NDArray]) -> None:
    """Raise the error a kernel status reports (NONFINITE, or a failed pivot of H)."""
    batched = isinstance(status, np.ndarray)
    st = np.atleast_1d(status)
    if not (st != OK).any():
        return
    if np.any(st == NONFINITE):
        for k, v in states.items():
            width = 6 if k == "f_ext" else 3 if k == "f_ext_point" else robot.n
            _array(v, k, width)
    if np.any(st == OVERFLOW):
        b = int(np.flatnonzero(st == OVERFLOW)[0])
        where = f"state {b}: " if batched else ""
        raise MrneaError(
            f"{where}the result is not finite although every input is: the state or the "
            f"robot '{robot.name}' holds values too large for float64 arithmetic")
    b = int(np.flatnonzero(st >= 0)[0])
    where = f"state {b}: " if batched else ""
    raise SingularMassMatrixError(
        f"{where}the mass matrix H is singular or not positive definite (pivot of joint "
        f"'{robot.joint_names[int(st[b])]}'); is a moving link, with everything it carries, "
        f"massless?"
    )


def _evaluate(
    robot: Robot,
    kernel: _Entry,
    kernel_batch: nb.core.registry.CPUDispatcher,
    states: dict[str, ArrayLike],
    f_ext: ArrayLike | None,
    f_ext_point: ArrayLike | None,
    shapes: Callable[[int], tuple[tuple[int, ...], ...]],
) -> list[NDArray[np.float64]]:
    """The validated path every public function shares: check and broadcast the inputs, run
    the single-state kernel or the batch kernel, raise what its status reports. ``shapes(n)``:
    the outputs' shapes for one state (a batch prepends B). Returns the outputs."""
    batched, arrays, fe, pe = _inputs(robot, states, f_ext, f_ext_point)
    m = robot.compiled
    if batched:
        B = arrays[0].shape[0]
        outputs = [np.empty((B, *shape)) for shape in shapes(robot.n)]
        status = np.empty(B, dtype=np.int64)
        kernel_batch(m, *arrays, fe, pe, *outputs, status)
    else:
        outputs = [np.empty(shape) for shape in shapes(robot.n)]
        if f_ext is None:  # a point without a force changes nothing
            status = kernel.free(m, *arrays, None, None, *outputs, robot._scratch)
        else:
            status = kernel.call(m, *arrays, fe, pe, *outputs, robot._scratch)
    if batched or status != OK:
        _check(robot, status, {**states, "f_ext": f_ext, "f_ext_point": f_ext_point})
    return outputs


def inverse_dynamics(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    qdd: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Joint efforts ``tau = H(q) qdd + C(q, qd) qd + g(q) + J^T f_ext`` (Eq. 1) by the RNEA.

    Returns tau, (n,) or (B, n) [N m | N]. See the module docstring for shapes and ``f_ext``.
    """
    if f_ext is None and f_ext_point is None:
        try:  # the fast path (module docstring)
            if q.dtype is qd.dtype is qdd.dtype is _F64 and q.ndim == qd.ndim == qdd.ndim == 1:
                tau = np.empty(robot._shape)
                if _RNEA.free(robot.compiled, q, qd, qdd, None, None, tau, robot._scratch) == OK:
                    return tau
        except (AttributeError, TypeError):
            pass
    args = {"q": q, "qd": qd, "qdd": qdd}
    (tau,) = _evaluate(robot, _RNEA, rnea_batch, args, f_ext, f_ext_point, lambda n: ((n,),))
    return tau


def mass_matrix_and_bias(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
    method: Literal["mrnea", "walker_orin"] = "mrnea",
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The mass matrix H and bias u' with ``tau = H qdd + u'`` (Eqs. 2-3, 34-36).

    ``method="mrnea"`` (default) computes both in the paper's single modified RNEA pass;
    ``"walker_orin"`` by Walker-Orin method 1 (n + 1 Newton-Euler passes), for comparison.
    Returns H, (n, n) or (B, n, n), and u', (n,) or (B, n). u' includes gravity and f_ext.
    """
    kernel, kernel_batch = _method(method, _HB)
    if f_ext is None and f_ext_point is None:
        try:  # the fast path (module docstring)
            if q.dtype is qd.dtype is _F64 and q.ndim == qd.ndim == 1:
                n = robot.n
                H, u = np.empty((n, n)), np.empty(n)
                if kernel.free(robot.compiled, q, qd, None, None, H, u, robot._scratch) == OK:
                    return H, u
        except (AttributeError, TypeError):
            pass
    H, u = _evaluate(robot, kernel, kernel_batch, {"q": q, "qd": qd}, f_ext, f_ext_point,
                     lambda n: ((n, n), (n,)))
    return H, u


def forward_dynamics(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    tau: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
    method: Method = "mrnea",
) -> NDArray[np.float64]:
    """Joint accelerations qdd from efforts tau: solves ``H qdd = tau - u'`` (Eq. 2).

    ``method``: ``"mrnea"`` (default; the paper: one mRNEA pass and a Cholesky solve),
    ``"walker_orin"`` (method 1, n + 1 RNEA passes), ``"crba"`` (composite-rigid-body H, RNEA
    bias), ``"aba"`` (articulated-body algorithm, O(n)). Returns qdd, (n,) or (B, n).
    Raises SingularMassMatrixError where H is not positive definite.
    """
    kernel, kernel_batch = _method(method, _FD)
    if f_ext is None and f_ext_point is None:
        try:  # the fast path (module docstring)
            if q.dtype is qd.dtype is tau.dtype is _F64 and q.ndim == qd.ndim == tau.ndim == 1:
                qdd = np.empty(robot._shape)
                if kernel.free(robot.compiled, q, qd, tau, None, None, qdd, robot._scratch) == OK:
                    return qdd
        except (AttributeError, TypeError):
            pass
    args = {"q": q, "qd": qd, "tau": tau}
    (qdd,) = _evaluate(robot, kernel, kernel_batch, args, f_ext, f_ext_point, lambda n: ((n,),))
    return qdd


def joint_reactions(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    qdd: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Each joint's 6-axis reaction wrench, for bearing and link design (Eqs. 18-19, 32).

    Returns (n, 6) or (B, n, 6): row i is ``[f; n]``, the force [N] and moment [N m] that link
    i-1 (the base for i = 0) exerts on link i through joint i, expressed in joint i's frame
    (the parent link's frame moved by the joint origin: fixed to the parent, z-free for a
    URDF joint with axis z) with the moment taken about that frame's origin, a point of the
    joint axis. The component along the joint axis of the moment (revolute) or force
    (prismatic) is the joint effort tau_i; the rest is what the bearing carries.
    """
    if f_ext is None and f_ext_point is None:
        try:  # the fast path (module docstring)
            if q.dtype is qd.dtype is qdd.dtype is _F64 and q.ndim == qd.ndim == qdd.ndim == 1:
                out = np.empty((robot.n, 6))
                ws = robot._scratch
                if _REACTIONS.free(robot.compiled, q, qd, qdd, None, None, out, ws) == OK:
                    return out
        except (AttributeError, TypeError):
            pass
    args = {"q": q, "qd": qd, "qdd": qdd}
    (out,) = _evaluate(robot, _REACTIONS, reactions_batch, args, f_ext, f_ext_point,
                       lambda n: ((n, 6),))
    return out
