"""Checks shared by every TOML file mrnea reads: robots, sidecar actuator files and programs.

A :class:`TomlCheck` is made for one document. Each check returns the value, converted, or
raises the reader's error type (:class:`mrnea.errors.RobotFileError`,
:class:`mrnea.errors.ProgramFileError`) with the message ``<file>: <where>: <what>``: the file,
the table or entry at fault (``[program]``, ``joint 'elbow'``) and what is wrong with which key,
with a did-you-mean suggestion for a misspelt key.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import MrneaError, clip, listing, quote
from mrnea.io.source import read_text

__all__ = ["MAX_DEPTH", "TomlCheck", "did_you_mean", "read_text", "type_name"]

MAX_DEPTH = 32
"""Deepest nesting of arrays and tables accepted in a TOML document (mrnea's formats use 4)."""


def type_name(value: object) -> str:
    """The TOML name of a parsed value's type (table, array, string, boolean, int, float)."""
    return {dict: "table", list: "array", str: "string", bool: "boolean"}.get(
        type(value), type(value).__name__)


def did_you_mean(word: str, choices: Sequence[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``choices``, or an empty string."""
    close = difflib.get_close_matches(word, choices, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


class TomlCheck:
    """Parses one TOML document and checks its values, raising errors that name the file.

    Parameters
    ----------
    source : the file's name, first in every message.
    error : the error type raised (a :class:`mrnea.errors.MrneaError`).
    finite : True: numbers must be finite (``allow_inf`` lets infinities through where a
        limit may be unbounded). False: every float is passed on, for readers whose model
        checks the values and names the field itself.
    """

    def __init__(self, source: str, error: type[MrneaError], *, finite: bool = True) -> None:
        if not isinstance(source, str):
            raise error(f"source: expected a name for the document (str), got "
                        f"{type(source).__name__} {quote(source)}")
        self.source = source
        self._error = error
        self.finite = finite

    def error(self, where: str, what: str) -> MrneaError:
        """The error ``<source>: <where>: <what>`` (``<source>: <what>`` without ``where``, or
        when ``what``, a model's message, starts by naming ``where`` itself: it had said
        ``joint 'a': joint 'a': efficiency must be in [0.01, 1]``)."""
        if where and not what.startswith(f"{where}: "):
            return self._error(clip(f"{self.source}: {where}: {what}"))
        return self._error(clip(f"{self.source}: {what}"))

    def parse(self, text: str) -> dict[str, Any]:
        """The document, or an error with tomllib's message, line and column; a document
        nested deeper than :data:`MAX_DEPTH` is refused (tomllib would recurse until Python's
        stack runs out)."""
        if not isinstance(text, str):
            raise self._error(f"text: expected a TOML document (str), got {type(text).__name__} "
                              f"{quote(text)}")
        try:
            doc = tomllib.loads(text)
        except RecursionError:
            raise self.error("", f"invalid TOML: arrays or tables nested too deeply (more than "
                                 f"{MAX_DEPTH} levels)") from None
        except tomllib.TOMLDecodeError as exc:
            msg = str(exc)
            if "(at end of document)" in msg:  # give the line and column there too
                lines = text.splitlines() or [""]
                msg = msg.replace("(at end of document)", f"(at line {len(lines)}, column "
                                                          f"{len(lines[-1]) + 1}: end of document)")
            raise self.error("", f"invalid TOML: {msg}") from None
        if _depth(doc) > MAX_DEPTH:
            raise self.error("", f"invalid TOML: arrays or tables nested too deeply (more than "
                                 f"{MAX_DEPTH} levels)")
        return doc

    def check_keys(self, table: Mapping[str, Any], allowed: Sequence[str], where: str) -> None:
        """Every key of ``table`` is one of ``allowed`` (else: the closest one is suggested)."""
        for key in table:
            if key not in allowed:
                raise self.error(where, f"unknown key {quote(key)}{did_you_mean(key, allowed)}; "
                                        f"allowed keys: {listing(allowed, len(allowed))}")

    def require(self, table: Mapping[str, Any], key: str, where: str) -> Any:
        """``table[key]``; an error names the missing key."""
        if key not in table:
            raise self.error(where, f"missing required key '{key}'")
        return table[key]

    def table(self, value: Any, where: str, key: str) -> Mapping[str, Any]:
        """``value`` if it is a table."""
        if not isinstance(value, dict):
            raise self.error(where, f"'{key}' must be a table, got {type_name(value)} "
                                    f"{quote(value)}")
        return value

    def string(self, value: Any, where: str, key: str) -> str:
        """``value`` if it is a non-empty string."""
        if not isinstance(value, str) or not value:
            raise self.error(where, f"'{key}' must be a non-empty string, got {quote(value)}")
        return value

    def number(self, value: Any, where: str, key: str, *, allow_inf: bool = False) -> float:
        """``value`` as a float: an integer or a float, not a boolean (finite: see the class)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(where, f"'{key}' must be a number, got {type_name(value)} "
                                    f"{quote(value)}")
        v = float(value)
        if self.finite and (math.isnan(v) or (math.isinf(v) and not allow_inf)):
            raise self.error(where, f"'{key}' must be a finite number, got {v}")
        return v

    def vector(self, value: Any, where: str, key: str, length: int | None = None, *,
               allow_inf: bool = False) -> NDArray[np.float64]:
        """A non-empty array of numbers (of ``length`` of them if given) as a 1-D array."""
        if not isinstance(value, list) or not value or (length is not None
                                                         and len(value) != length):
            size = f"{length} numbers" if length is not None else "numbers"
            got = f"{len(value)} entries" if isinstance(value, list) else type_name(value)
            raise self.error(where, f"'{key}' must be an array of {size}, got {got}: "
                                    f"{quote(value)}")
        return np.array([self.number(v, where, f"{key}[{k}]", allow_inf=allow_inf)
                         for k, v in enumerate(value)])

    def matrix(self, value: Any, where: str, key: str, width: int | None = None,
               rows: int | None = None) -> NDArray[np.float64]:
        """An array of equal-length arrays of numbers; an error names the row (1-based)."""
        if not isinstance(value, list) or not value:
            raise self.error(where, f"'{key}' must be a non-empty array of arrays, got "
                                    f"{quote(value)}")
        if rows is not None and len(value) != rows:
            raise self.error(where, f"'{key}' has {len(value)} rows, expected {rows}")
        expected = width if width is not None else (
            len(value[0]) if isinstance(value[0], list) else None)
        out = []
        for r, row in enumerate(value, start=1):
            if not isinstance(row, list):
                raise self.error(where, f"'{key}' row {r} must be an array of numbers, got "
                                        f"{type_name(row)} {quote(row)}")
            if expected is not None and len(row) != expected:
                ref = "" if width is not None else " (the length of row 1)"
                raise self.error(where, f"'{key}' row {r} has {len(row)} values, expected "
                                        f"{expected}{ref}")
            out.append(self.vector(row, where, f"{key} row {r}"))
        return np.array(out)


def _depth(value: Any) -> int:
    """How deeply arrays and tables nest in a parsed document (a scalar: 0), without recursion."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, dict):
            v = list(v.values())
        if isinstance(v, list):
            deepest = max(deepest, d + 1)
            stack.extend((x, d + 1) for x in v if isinstance(x, (dict, list)))
    return deepest
