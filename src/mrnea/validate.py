"""Argument checks of the public API, in one place, and the translation of kernel status codes into
errors. Every check raises a :class:`mrnea.errors.StateError` whose message starts with the
offending argument's name.

This module imports NumPy and the plain status constants (kernels/status.py), not Numba: a module
that only checks its arguments (a time step, say) loads no kernel.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import MrneaError, SingularMassMatrixError, StateError, quote
from mrnea.frozen import MAGNITUDES
from mrnea.kernels.status import CYCLE_LIMIT, NONFINITE, OK, OVERFLOW
from mrnea.model import Robot

T = TypeVar("T")
_ZERO_WRENCH = np.zeros(6)  # f_ext=None, f_ext_point=None (kernels never write their inputs)
_ZERO_POINT = np.zeros(3)
_CYCLE_LIMIT = ("the exact cycle solve stopped at its step bound, which only rounding can reach "
                "(an extremely ill-conditioned mass matrix?); please report the case")


def require_robot(robot: object) -> None:
    """A StateError unless ``robot`` is a :class:`mrnea.Robot`."""
    if not isinstance(robot, Robot):
        raise StateError(f"robot: expected a mrnea.Robot, got {type(robot).__name__}")


def real(x: object, name: str) -> float:
    """``x`` as a float: a real number (not a bool, a complex number, a string or an array)."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Real):
        raise StateError(f"{name}: not a real number: {x!r}")
    return float(x)


#: The longest cycle time mrnea takes [s]: a controller's interpolation cycle is milliseconds;
#: beyond this a time step is a unit mistake (a duration in ms given as s, ...) and the times
#: it makes stop being readable numbers.
MAX_DT = 1e3


def time_step(dt: object, name: str = "dt") -> float:
    """dt [s] as a float: a real, finite number > 0 and at most :data:`MAX_DT` (:func:`real`)."""
    dt = real(dt, name)
    if not (math.isfinite(dt) and 0 < dt <= MAX_DT):
        raise StateError(f"{name}: must be a finite time step > 0 s and at most {MAX_DT:g} s, "
                         f"got {dt}")
    return dt


def flag(x: object, name: str) -> bool:
    """``x`` as a bool: True or False (NumPy's included), nothing else."""
    if not isinstance(x, (bool, np.bool_)):
        raise StateError(f"{name}: expected True or False, got {x!r}")
    return bool(x)


def fraction(x: object, name: str) -> float:
    """A real number in (0, 1] (:func:`real`), e.g. the planning margin of :func:`mrnea.retime`."""
    x = real(x, name)
    if not 0 < x <= 1:
        raise StateError(f"{name}: must be in (0, 1], got {x}")
    return x


def catch_up(gain: object, dt: float) -> float:
    """The position-loop gain [1/s] of :func:`mrnea.simulate.simulate`: 0 <= gain < 1/dt."""
    gain = real(gain, "catch_up")
    if not (0 <= gain and gain * dt < 1):
        raise StateError(f"catch_up: needs 0 <= catch_up < 1/dt = {1 / dt:g} 1/s, got {gain}")
    return gain


def choice(name: str, value: object, table: Mapping[str, T]) -> T:
    """``table[value]``; a StateError naming ``name`` for a value the table does not hold."""
    try:
        return table[value]  # type: ignore[index]
    except (KeyError, TypeError):  # TypeError: an unhashable value
        raise StateError(
            f"{name}: unknown {value!r}; expected one of {', '.join(map(repr, table))}"
        ) from None


def callable_or_none(fn: object, name: str) -> None:
    if fn is not None and not callable(fn):
        raise StateError(f"{name}: expected a callable or None, got {fn!r}")


def numeric(x: ArrayLike, name: str) -> NDArray[np.float64]:
    """``x`` as a C-contiguous, writable float64 array of any shape: real numbers only (not
    booleans, strings, objects, complex numbers, None or a ragged nesting, as :func:`real`);
    finiteness and shape are the caller's."""
    if x is None:
        raise StateError(f"{name}: expected an array of real numbers, got None")
    try:
        a = np.asarray(x)
    except (TypeError, ValueError):
        raise StateError(f"{name}: not a numeric array: {x!r}") from None
    if a.dtype.kind == "b":
        raise StateError(f"{name}: expected real numbers, got True/False: {quote(x)}")
    if a.dtype.kind not in "iuf":
        raise StateError(f"{name}: expected real numbers, got an array of {a.dtype}")
    return np.require(a, dtype=np.float64, requirements=["C", "W"])


def array(x: ArrayLike, name: str, width: int) -> NDArray[np.float64]:
    """``x`` as a C-contiguous, writable float64 array of shape (width,) or (B, width), all
    finite (the kernels are compiled for exactly such arrays)."""
    a = numeric(x, name)
    if a.ndim not in (1, 2) or a.shape[-1] != width or (a.ndim == 2 and a.shape[0] == 0):
        raise StateError(f"{name}: expected shape ({width},) or (B, {width}), got {a.shape}")
    if not np.isfinite(a).all():
        bad = np.argwhere(~np.isfinite(a))[0]
        raise StateError(f"{name}: contains NaN or inf (first at index {tuple(bad.tolist())})")
    return a


def per_joint(x: ArrayLike, name: str, n: int) -> NDArray[np.float64]:
    """A value per joint, (n,): one number for every joint (a scalar or a sequence of one) or n
    numbers (:func:`array`)."""
    try:
        shape = np.shape(x)
    except (TypeError, ValueError):  # a ragged nesting
        raise StateError(f"{name}: not a numeric array: {quote(x)}") from None
    scalar = shape in ((), (1,))
    a = array(np.ravel(x) if scalar else x, name, 1 if scalar else n)
    if a.ndim != 1:
        raise StateError(f"{name}: expected one number or ({n},), got shape {a.shape}")
    return np.full(n, a[0]) if scalar else a


#: The largest force [N] or moment [N m] a simulation takes in a wrench: the weight of the
#: heaviest robot mrnea accepts (1e7 kg at 1e3 m/s^2, mrnea.frozen.MAGNITUDES). Beyond, the
#: cycle's exact solve loses its digits (1e21 N ended in its step bound). Its point: the
#: largest length, MAGNITUDES["length"].
WRENCH_BOUND = 1e10


def wrench_per_cycle(robot: Robot, f_ext: object, f_ext_point: object, K: int
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A simulation's wrench, one per cycle: the last link's, (K, 6) and (K, 3)
    (:func:`per_cycle`), or by link name (mappings, :func:`link_wrenches`), (K, n, 6) and
    (K, n, 3); within :data:`WRENCH_BOUND` and, the point, the largest length."""
    if by_link(f_ext, f_ext_point):
        fe, pe = link_wrenches(robot, f_ext, f_ext_point, rows=K)
        if fe.ndim == 2:
            fe, pe = np.broadcast_to(fe, (K, *fe.shape)), np.broadcast_to(pe, (K, *pe.shape))
        fe, pe = np.ascontiguousarray(fe), np.ascontiguousarray(pe)
    else:
        fe, pe = per_cycle(f_ext, K, 6, "f_ext"), per_cycle(f_ext_point, K, 3, "f_ext_point")
    for a, name, bound, unit in ((fe, "f_ext", WRENCH_BOUND, "N (or N m)"),
                                 (pe, "f_ext_point", MAGNITUDES["length"], "m")):
        if a.size and np.abs(a).max() > bound:
            raise StateError(f"{name}: {np.abs(a).max():.3g} is beyond {bound:g} {unit}, the "
                             f"largest mrnea simulates; check its units")
    return fe, pe


def program_wrench(robot: Robot, f_ext: object, f_ext_point: object, K: int
                   ) -> tuple[Any, Any]:
    """A program's wrench on its K rows, kept in the form it was given (a retiming moves it with
    the path, a sizing takes it to every duty): the last link's, f_ext (K, 6) or None and
    f_ext_point (3,), (K, 3) or None; or by link name (mappings, :func:`link_wrenches` checks
    them), ``{link: (K, 6)}`` and ``{link: (3,) or (K, 3)}`` with every name the robot's own."""
    if by_link(f_ext, f_ext_point):
        fe, pe = link_wrenches(robot, f_ext, f_ext_point, rows=K)
        loads, where = {}, {}
        for k in f_ext or {}:
            i = robot.link_index(k, "f_ext", StateError)
            loads[robot.link_names[i]] = np.ascontiguousarray(fe[:, i])
        for k, v in (f_ext_point or {}).items():
            i = robot.link_index(k, "f_ext_point", StateError)
            where[robot.link_names[i]] = (pe[0, i].copy() if np.ndim(v) == 1
                                          else np.ascontiguousarray(pe[:, i]))
        return loads, where
    fe = None if f_ext is None else per_cycle(f_ext, K, 6, "f_ext")
    pe = None
    if f_ext_point is not None:
        pe = array(f_ext_point, "f_ext_point", 3)
        if pe.ndim == 2 and pe.shape[0] != K:
            raise StateError(f"f_ext_point: expected (3,) or ({K}, 3), got {pe.shape}")
    return fe, pe


def wrench_map(x: Any, f: Callable[[NDArray], NDArray]) -> Any:
    """``f`` applied to a wrench or its point in either form of :func:`program_wrench`: the
    last link's array, or each link's of a mapping by link name; None stays None."""
    if x is None:
        return None
    if isinstance(x, Mapping):
        return {k: f(v) for k, v in x.items()}
    return f(x)


def wrench_rows(x: Any, rows: Any) -> Any:
    """The rows ``rows`` (an index, a slice or an index array) of a wrench or its point in
    either form of :func:`program_wrench`; a single row (m,), every instant's, stays."""
    return wrench_map(x, lambda a: a if a.ndim == 1 else a[rows])


def per_cycle(x: ArrayLike | None, K: int, width: int, name: str) -> NDArray[np.float64]:
    """A value per simulation cycle, (K, width): ``None`` (zeros), one row for every cycle, or
    K rows."""
    if x is None:
        return np.zeros((K, width))
    a = array(x, name, width)
    if a.ndim == 1:
        return np.ascontiguousarray(np.broadcast_to(a, (K, width)))
    if a.shape[0] != K:
        raise StateError(f"{name}: expected ({width},) or ({K}, {width}) rows, got {a.shape}")
    return np.ascontiguousarray(a)


def inputs(
    robot: Robot,
    states: dict[str, ArrayLike],
    f_ext: ArrayLike | None,
    f_ext_point: ArrayLike | None,
) -> tuple[bool, list[NDArray], NDArray, NDArray]:
    """Check and broadcast the arguments of a dynamics call: ``states`` (n,) or (B, n) each,
    the wrench f_ext (6,) or (B, 6) and its point (3,) or (B, 3) (None: zero). Returns
    (batched, states, f_ext, f_ext_point); batched arrays are 2-D."""
    require_robot(robot)
    n = robot.n
    arrays = {k: array(v, k, n) for k, v in states.items()}
    if by_link(f_ext, f_ext_point):  # per-link arrays, flattened to broadcast like a state
        fe, pe = link_wrenches(robot, f_ext, f_ext_point)
        arrays["f_ext"] = fe.reshape(*fe.shape[:-2], 6 * n)
        arrays["f_ext_point"] = pe.reshape(*pe.shape[:-2], 3 * n)
        batched, out = _broadcast(arrays)
        shape = (-1, n) if batched else (n,)
        return (batched, out[:-2], np.ascontiguousarray(out[-2].reshape(*shape, 6)),
                np.ascontiguousarray(out[-1].reshape(*shape, 3)))
    arrays["f_ext"] = _ZERO_WRENCH if f_ext is None else array(f_ext, "f_ext", 6)
    arrays["f_ext_point"] = (_ZERO_POINT if f_ext_point is None
                             else array(f_ext_point, "f_ext_point", 3))
    batched, out = _broadcast(arrays)
    return batched, out[:-2], out[-2], out[-1]


def by_link(f_ext: object, f_ext_point: object) -> bool:
    """True when the wrench is given by link name (a mapping), not as the last link's array."""
    return isinstance(f_ext, Mapping) or isinstance(f_ext_point, Mapping)


def link_wrenches(robot: Robot, f_ext: Mapping[str, ArrayLike] | None,
                  f_ext_point: Mapping[str, ArrayLike] | None, rows: int | None = None
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Wrenches by link name as per-link arrays, what the kernels take for a wrench per body.

    ``f_ext``: ``{link: [f; n]}``, each (6,) or (B, 6) [N, N m], base coordinates, the wrench
    that link exerts on its environment; ``f_ext_point``: ``{link: p}``, each (3,) or (B, 3)
    [m], the point in that link's frame where it acts (a link not given: its frame's origin).
    Returns (n, 6) and (n, 3), row i link i's (zero for a link without a wrench), or (B, n, 6)
    and (B, n, 3) when a value has B rows (``rows``: B required, as a simulation's K cycles).
    A StateError names an unknown link (with a close match), a point without its wrench or a
    mix of a mapping and an array."""
    # a mapping's own names and values first: an unknown link is named before a mix is
    fe_by = ({robot.link_index(k, "f_ext", StateError): array(v, f"f_ext[{k!r}]", 6)
              for k, v in f_ext.items()} if isinstance(f_ext, Mapping) else {})
    pe_by = ({robot.link_index(k, "f_ext_point", StateError):
              array(v, f"f_ext_point[{k!r}]", 3) for k, v in f_ext_point.items()}
             if isinstance(f_ext_point, Mapping) else {})
    for name, v in (("f_ext", f_ext), ("f_ext_point", f_ext_point)):
        if v is not None and not isinstance(v, Mapping):
            raise StateError(f"{name}: with the wrench given by link name, give {name} as a "
                             f"mapping {{link: value}} too, or None; got {type(v).__name__}")
    for i in pe_by.keys() - fe_by.keys():
        raise StateError(f"f_ext_point: a point for link {robot.link_names[i]!r}, which "
                         f"f_ext gives no wrench")
    sizes = {a.shape[0] for a in (*fe_by.values(), *pe_by.values()) if a.ndim == 2}
    if rows is not None:
        sizes.add(rows)
    if len(sizes) > 1:
        raise StateError(f"f_ext, f_ext_point by link: row counts differ ({sorted(sizes)}); "
                         f"give each value one row or {rows or 'B'} rows")
    lead = (sizes.pop(),) if sizes else ()
    n = robot.n
    fe, pe = np.zeros((*lead, n, 6)), np.zeros((*lead, n, 3))
    for i, a in fe_by.items():
        fe[..., i, :] = a
    for i, a in pe_by.items():
        pe[..., i, :] = a
    return fe, pe


def kinematics_inputs(robot: Robot, q: ArrayLike, point: ArrayLike | None
                      ) -> tuple[bool, NDArray, NDArray]:
    """Check and broadcast the arguments of a kinematics call: q (n,) or (B, n), a point
    (3,) or (B, 3) (None: zero). Returns (batched, q, point); batched arrays are 2-D."""
    require_robot(robot)
    arrays = {"q": array(q, "q", robot.n),
              "point": _ZERO_POINT if point is None else array(point, "point", 3)}
    batched, (q, p) = _broadcast(arrays)
    return batched, q, p


def _broadcast(arrays: dict[str, NDArray]) -> tuple[bool, list[NDArray]]:
    """Arrays of one state (1-D) or a batch (2-D, one B for all) by name: (batched, arrays),
    every array 2-D with B rows when any is."""
    if all(a.ndim == 1 for a in arrays.values()):
        return False, list(arrays.values())
    sizes = {a.shape[0] for a in arrays.values() if a.ndim == 2}
    if len(sizes) > 1:
        shapes = ", ".join(f"{k} {a.shape}" for k, a in arrays.items())
        raise StateError(f"batch sizes differ: {shapes}")
    B = sizes.pop()
    return True, [a if a.ndim == 2 else np.repeat(a[None], B, axis=0) for a in arrays.values()]


def one_state(
    robot: Robot,
    states: dict[str, ArrayLike],
    f_ext: ArrayLike | None,
    f_ext_point: ArrayLike | None,
    who: str,
) -> tuple[dict[str, NDArray], NDArray, NDArray]:
    """The arguments of a function ``who`` that takes one state, not a batch: ``states`` (n,)
    each, f_ext (6,) and f_ext_point (3,) (None: zero). Returns the states by name, f_ext and
    f_ext_point."""
    require_robot(robot)
    arrays = {k: array(v, k, robot.n) for k, v in states.items()}
    if any(a.ndim != 1 for a in arrays.values()):
        raise StateError(f"{who} takes one state: arrays of shape ({robot.n},)")
    if by_link(f_ext, f_ext_point):
        fe, pe = link_wrenches(robot, f_ext, f_ext_point)
        if fe.ndim != 2:
            raise StateError(f"{who} takes one state: f_ext {{link: (6,)}}, f_ext_point "
                             f"{{link: (3,)}}")
        return arrays, fe, pe
    fe = _ZERO_WRENCH if f_ext is None else array(f_ext, "f_ext", 6)
    pe = _ZERO_POINT if f_ext_point is None else array(f_ext_point, "f_ext_point", 3)
    if fe.ndim != 1 or pe.ndim != 1:
        raise StateError(f"{who} takes one state: f_ext (6,), f_ext_point (3,)")
    return arrays, fe, pe


def check_status(robot: Robot, status: int | NDArray, states: dict[str, object]) -> None:
    """Raise the error a kernel's status reports (one state's int, or a batch's array):
    NONFINITE names the argument, OVERFLOW the values too large, a pivot index the joint where
    H is singular. ``states``: the arguments as the caller gave them, by name."""
    batched = isinstance(status, np.ndarray)
    st = np.atleast_1d(status)
    if not (st != OK).any():
        return
    if np.any(st == NONFINITE):
        for k, v in states.items():
            if v is not None and not isinstance(v, Mapping):  # a mapping: checked already
                array(v, k, {"f_ext": 6, "f_ext_point": 3, "point": 3}.get(k, robot.n))
    if np.any(st == OVERFLOW):
        b = int(np.flatnonzero(st == OVERFLOW)[0])
        where = f"state {b}: " if batched else ""
        raise MrneaError(
            f"{where}the result is not finite although every input is: the state or the "
            f"robot '{robot.name}' holds values too large for float64 arithmetic")
    if np.any(st == CYCLE_LIMIT):
        b = int(np.flatnonzero(st == CYCLE_LIMIT)[0])
        raise MrneaError((f"state {b}: " if batched else "") + _CYCLE_LIMIT)
    b = int(np.flatnonzero(st >= 0)[0])
    where = f"state {b}: " if batched else ""
    raise SingularMassMatrixError(
        f"{where}the mass matrix H is singular or not positive definite (pivot of joint "
        f"'{robot.joint_names[int(st[b])]}'); is a moving link, with everything it carries, "
        f"massless?"
    )


def check_cycle(robot: Robot, k: int, status: int, q: NDArray, qd: NDArray, dt: float) -> None:
    """Raise the error the simulation loop's status (not OK) reports for cycle k at state q, qd."""
    if status in (NONFINITE, OVERFLOW):
        raise MrneaError(
            f"cycle {k} (t = {k * dt:.6g} s): the state became non-finite (q = {q.tolist()}, "
            f"qd = {qd.tolist()}); check the program and the robot's limits")
    if status == CYCLE_LIMIT:
        raise MrneaError(f"cycle {k} (t = {k * dt:.6g} s): {_CYCLE_LIMIT}")
    raise SingularMassMatrixError(
        f"cycle {k} (t = {k * dt:.6g} s): the mass matrix is singular (pivot of joint "
        f"'{robot.joint_names[status]}') at q = {q.tolist()}")

