"""Immutable, validated value objects (the Robot, Joint and Link of :mod:`mrnea.model`).

:class:`Frozen` gives them equality by value (arrays compared by value, ``-0.0 == 0.0``), a hash
by value (computed once), and copies through their constructor: ``pickle``, ``copy.copy`` and
``copy.deepcopy`` call :func:`_rebuild` (``__reduce__``), so that every copy is validated again
and its arrays are the constructor's read-only ones. The ``ModelWarning``s the original's
construction gave are not repeated for its copies (:func:`warn`).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable
from contextvars import ContextVar
from typing import Any

import numpy as np

from mrnea.errors import ModelWarning

# True while an object is rebuilt from a validated original (unpickling, copying)
_REBUILDING: ContextVar[bool] = ContextVar("mrnea_rebuilding", default=False)


def warn(message: str, stacklevel: int) -> None:
    """A ModelWarning, unless an object is being rebuilt (``stacklevel`` as warnings.warn's)."""
    if not _REBUILDING.get():
        warnings.warn(message, ModelWarning, stacklevel=stacklevel + 1)


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
