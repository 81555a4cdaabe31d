"""Immutable, validated value objects (the Robot, Joint and Link of :mod:`mrnea.model`, the
Visual of :mod:`mrnea.visual`).

:class:`Frozen` gives them equality by value (arrays compared by value, ``-0.0 == 0.0``), a hash
by value (computed once), and copies through their constructor: ``pickle``, ``copy.copy`` and
``copy.deepcopy`` call :func:`_rebuild` (``__reduce__``), so that every copy is validated again
and its arrays are the constructor's read-only ones. The ``ModelWarning``s the original's
construction gave are not repeated for its copies (:func:`warn`). The checks of their fields
are here too: :func:`frozen_array`, :func:`rigid_transform`, :func:`real_number`,
:func:`check_name`, :func:`check_magnitude` (:data:`MAGNITUDES`).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import re
import warnings
from collections.abc import Callable
from contextvars import ContextVar
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import ModelError, ModelWarning, quote

# True while an object is rebuilt from a validated original (unpickling, copying)
_REBUILDING: ContextVar[bool] = ContextVar("mrnea_rebuilding", default=False)


def warn(message: str, stacklevel: int) -> None:
    """A ModelWarning, unless an object is being rebuilt (``stacklevel`` as warnings.warn's)."""
    if not _REBUILDING.get():
        warnings.warn(message, ModelWarning, stacklevel=stacklevel + 1)


def frozen_array(a: ArrayLike, shape: tuple[int, ...], what: str) -> NDArray[np.float64]:
    """A read-only float64 copy of ``a`` with the given shape, all entries finite real numbers
    (never text, bytes or bools, as :func:`real_number`: NumPy would read ``"1.0"`` as 1)."""
    try:
        if np.iscomplexobj(a):
            raise TypeError("complex numbers, expected real ones")
        raw = np.asarray(a)
        if raw.dtype.kind in "USb" or (raw.dtype.kind == "O" and any(
                isinstance(v, (str, bytes, bool, np.bool_)) for v in raw.flat)):
            raise TypeError(f"expected real numbers, got {quote(a)}")
        arr = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{what}: not a numeric array ({exc})") from None
    if arr.shape != shape:
        raise ModelError(f"{what}: expected shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{what}: contains NaN or infinite values: {arr.tolist()}")
    arr.setflags(write=False)
    return arr


def rigid_transform(a: ArrayLike, what: str) -> NDArray[np.float64]:
    """:func:`frozen_array` of a (4, 4) homogeneous transform whose rotation is proper
    (orthonormal to 1e-6, determinant > 0) and whose last row is exactly (0, 0, 0, 1)."""
    T = frozen_array(a, (4, 4), what)
    R = T[:3, :3]
    if (np.max(np.abs(R @ R.T - np.eye(3))) > 1e-6 or np.linalg.det(R) < 0
            or np.max(np.abs(T[3] - (0, 0, 0, 1))) > 0):
        raise ModelError(f"{what} is not a rigid transform: {T.tolist()}")
    return T


_NOT_IN_XML = re.compile("[\x00-\x1f\x7f\ufffe\uffff\ud800-\udfff]")


def check_name(name: object, kind: str) -> None:
    """A non-empty string without control characters (URDF/XML cannot hold them)."""
    if not isinstance(name, str) or not name:
        raise ModelError(f"{kind} name must be a non-empty string, got {name!r}")
    if _NOT_IN_XML.search(name):
        raise ModelError(f"{kind} name {name!r} contains control characters (or other "
                         f"characters a URDF file cannot hold)")


def real_number(x: object, what: str, *, allow_inf: bool = False) -> float:
    """``x`` as a float: a real number (int, float, NumPy scalar), never text or bytes (Python's
    ``float("1_0")`` is 10) nor a bool."""
    if isinstance(x, (str, bytes, bool, np.bool_)) or not isinstance(x, (numbers.Real, np.number)):
        raise ModelError(f"{what}: not a number: {quote(x)}")
    try:
        v = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):
        raise ModelError(f"{what}: not a number: {quote(x)}") from None
    if math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise ModelError(f"{what}: must be a finite number, got {v}")
    return v


#: The largest magnitude mrnea accepts for each physical field of a robot, SI units (gravity and
#: lengths per component, inertia per entry; velocity, position and effort limits are not
#: bounded: a limit is only compared with). Beyond them the dynamics lose every digit to
#: rounding or overflow (m g l, G^2 J_m against the links' inertia, a friction that swamps
#: every other term) and no machine comes near: the largest built-in robot, the SDT, has 7492 kg,
#: 1.3e4 kg m^2, 3 m, a 0.6 kg m^2 rotor and 800 N m of friction. docs/robot-format.md.
MAGNITUDES = {"gravity": 1e3, "length": 1e4, "mass": 1e7, "inertia": 1e10,
              "rotor_inertia": 1e3, "viscous_friction": 1e9, "coulomb_friction": 1e9}


def check_magnitude(value: ArrayLike, field: str, what: str, unit: str) -> None:
    """A ModelError naming ``what`` and ``field`` if any entry of ``value`` exceeds
    :data:`MAGNITUDES` [``field``] in magnitude."""
    bound = MAGNITUDES[field]
    big = float(np.max(np.abs(np.asarray(value, dtype=float))))
    if big > bound:
        shown = f"{big:.3g}" if f"{big:.3g}" != f"{bound:g}" else repr(big)  # not "1e+07 > 1e+07"
        raise ModelError(f"{what}: {field.replace('_', ' ')} {shown} {unit} is beyond "
                         f"{bound:g} {unit}, the largest mrnea accepts (the dynamics would lose "
                         "every digit to rounding); check its units")


def _rebuild(cls: Callable[..., Any], state: dict[str, Any]) -> Any:
    """``cls(**state)``, validated, without repeating the original's warnings."""
    token = _REBUILDING.set(True)
    try:
        return cls(**state)
    finally:
        _REBUILDING.reset(token)


def _value(x: object) -> object:
    """A hashable value of a field: arrays as (shape, entries) tuples."""
    if isinstance(x, np.ndarray):
        return (x.shape, tuple(x.ravel().tolist()))
    return x


class Frozen:
    """Value semantics for an immutable class whose constructor validates: ``_state()`` returns
    the keyword arguments that rebuild the object (a dataclass's fields by default)."""

    def _state(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}  # type: ignore[arg-type]

    def _key(self) -> tuple:
        try:
            return self.__dict__["_frozen_key"]
        except KeyError:
            key = tuple(_value(v) for v in self._state().values())
            object.__setattr__(self, "_frozen_key", key)
            return key

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self is other or self._key() == other._key()  # type: ignore[attr-defined]

    def __hash__(self) -> int:
        try:
            return self.__dict__["_frozen_hash"]
        except KeyError:
            h = hash((type(self).__name__, self._key()))
            object.__setattr__(self, "_frozen_hash", h)
            return h

    def __reduce__(self) -> tuple:
        return (_rebuild, (type(self), self._state()))
