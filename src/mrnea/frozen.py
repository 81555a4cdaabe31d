"""Immutable, validated value objects (the Robot, Joint and Link of :mod:`mrnea.model`, the
Visual of :mod:`mrnea.visual`).

:class:`Frozen` gives them equality by value (arrays compared by value, ``-0.0 == 0.0``), a hash
by value (computed once), and copies through their constructor: ``pickle``, ``copy.copy`` and
``copy.deepcopy`` call :func:`_rebuild` (``__reduce__``), so that every copy is validated again
and its arrays are the constructor's read-only ones. The ``ModelWarning``s the original's
construction gave are not repeated for its copies (:func:`warn`). The array checks they share
are here too: :func:`frozen_array`, :func:`rigid_transform`.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable
from contextvars import ContextVar
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import ModelError, ModelWarning

# True while an object is rebuilt from a validated original (unpickling, copying)
_REBUILDING: ContextVar[bool] = ContextVar("mrnea_rebuilding", default=False)


def warn(message: str, stacklevel: int) -> None:
    """A ModelWarning, unless an object is being rebuilt (``stacklevel`` as warnings.warn's)."""
    if not _REBUILDING.get():
        warnings.warn(message, ModelWarning, stacklevel=stacklevel + 1)


def frozen_array(a: ArrayLike, shape: tuple[int, ...], what: str) -> NDArray[np.float64]:
    """A read-only float64 copy of ``a`` with the given shape, all entries finite."""
    try:
        arr = np.array(a, dtype=np.float64)
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
