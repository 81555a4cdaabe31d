"""The package's error types.

Every error mrnea raises on bad input is a subclass of :class:`MrneaError`, itself a
:class:`ValueError`, and its message names the offending element (link, joint, file, argument).

Messages quote what the user gave through two helpers, so that no input, however large, makes a
message large: :func:`quote` (one value, its ``repr`` cut to :data:`QUOTE_LIMIT` characters),
:func:`shorten` (a name, cut the same way) and :func:`listing` (a list of names: the first
:data:`LIST_LIMIT`, then "and N more"); :func:`clip` shortens what a message built elsewhere
quoted whole.
"""

from __future__ import annotations

import re
import reprlib
from collections.abc import Iterable

QUOTE_LIMIT = 60
"""At most this many characters of a value are quoted in a message (:func:`quote`)."""
LIST_LIMIT = 10
"""At most this many items of a list are named in a message (:func:`listing`)."""

_REPR = reprlib.Repr()  # containers summarised: a few levels and items, strings cut
_REPR.maxlevel, _REPR.maxstring, _REPR.maxother = 3, QUOTE_LIMIT, QUOTE_LIMIT


def quote(value: object, limit: int = QUOTE_LIMIT) -> str:
    """``repr(value)`` on one line, shortened to at most ``limit`` characters, ``...`` marking a
    cut.

    Strings and bytes are cut before ``repr`` runs and containers are summarised
    (:mod:`reprlib`), so quoting a value of any size costs little.
    """
    if isinstance(value, (str, bytes)):
        text = repr(value[:limit + 1])
        if len(text) > limit:  # cut inside the quotes: 'abc...'
            text = repr(value[:limit - 5])
            text = text[:-1][:limit - 4] + "..." + text[-1]
        return text
    else:
        try:
            text = _REPR.repr(value)
        except Exception:  # a user object whose __repr__ fails
            text = f"<{type(value).__name__}>"
        text = re.sub(r"\s*\n\s*", " ", text)  # one line: an array's repr spans several
    return text if len(text) <= limit else text[:limit - 3] + "..."


def listing(items: Iterable[object], limit: int = LIST_LIMIT, sep: str = ", ") -> str:
    """The first ``limit`` items (each a name, shortened as :func:`quote` shortens a string),
    then ``and N more``: ``a, b, c and 17 more``."""
    items = list(items)
    shown = [shorten(str(x)) for x in items[:limit]]
    more = len(items) - len(shown)
    return sep.join(shown) + (f" and {more} more" if more > 0 else "")


# a name quoted whole: after a space or "(", before a colon, space, comma or ")"
_LONG_QUOTE = re.compile(f"(?<=[ (])'([^'\\n]{{{QUOTE_LIMIT - 1},}})'(?=[:;,) ]|$)")


def clip(message: str) -> str:
    """``message`` with every quoted text longer than :data:`QUOTE_LIMIT` shortened: for a
    message built elsewhere that quotes a name whole (``joint 'x...x': axis is zero``) before a
    reader adds its file and element to it."""
    return _LONG_QUOTE.sub(lambda m: quote(m.group(1)), message)


def shorten(text: str, limit: int = QUOTE_LIMIT) -> str:
    """``text`` (a name, say) cut to at most ``limit`` characters, ``...`` marking a cut."""
    return text if len(text) <= limit else text[:limit - 3] + "..."


class MrneaError(ValueError):
    """Base class of every mrnea input error.

    ``cli``: the message as the command line says it, where the library's names an API
    argument the command line spells another way (``overwrite=True`` is ``--force`` there); the
    ``mrnea`` command prints it instead of the message. None: the same message for both.
    """

    def __init__(self, *args: object, cli: str | None = None) -> None:
        super().__init__(*args)
        self.cli = cli


class ModelError(MrneaError):
    """A robot description is not physical or not consistent (mass, inertia, axis, limits...)."""


class RobotFileError(ModelError):
    """A robot file (URDF, native TOML/YAML, DH table) cannot be read or parsed."""


class ProgramFileError(MrneaError):
    """A program file (TOML) or path CSV cannot be read, parsed or validated.

    The message names the file and the key, row or column at fault (TOML syntax errors: line
    and column).
    """


class StateError(MrneaError):
    """A state or argument passed to the public API has the wrong shape, type or value."""


class SingularMassMatrixError(MrneaError):
    """The joint-space mass matrix H is singular or not positive definite at this state.

    This happens, for example, when a moving link and everything it carries is massless.
    """


class RetimeError(MrneaError):
    """A program cannot be retimed: its path cannot be followed at any speed (a pose the robot
    cannot hold against gravity or a wrench; the message names the joint, the instant and the
    ratio of need to limit), it leaves the joint's position limits, or no planning margin gives a
    program the verifying simulation accepts."""


class NoTimingError(RetimeError):
    """No timing of the program's path is achievable: a pose on it the robot cannot hold
    against gravity, a wrench and friction (its need over the effort limit), a point of it
    outside a joint's position limits, or no planning margin (or scale factor) whose timing the
    verifying simulation accepts. A verdict about the program, not bad input: ``mrnea retime``
    prints it as ``NOT ACHIEVABLE`` and exits 1. The other :class:`RetimeError` cases (a
    program that never moves, no limit that binds, a cycle too coarse for the path, a planning
    margin below what a dwell needs) are bad input (exit 2)."""


class JerkLimitError(RetimeError):
    """The jerk limits given to a jerk-limited retiming are too small to plan the path with:
    about the ``jerk_limit`` argument (``--jerk-limit`` on the command line), not the program.
    ``str()`` is ``"jerk_limit: " + detail``; ``detail`` says why, without the argument's
    name."""

    def __init__(self, detail: str) -> None:
        super().__init__(f"jerk_limit: {detail}")
        self.detail = detail


class OutputError(MrneaError):
    """An output file cannot be written: it exists (and replacing it was not allowed), its place
    is a directory, its folder is missing or not writable, or another run owns the folder."""


class SweepError(MrneaError):
    """A design sweep cannot start: its grid (an unknown parameter or joint, an empty list, a
    value the robot cannot take), its grid file, its programs or its cluster. The message names
    the grid entry, file or program at fault; it is raised before any simulation runs."""


class LogFileError(MrneaError):
    """A measurement log cannot be used for identification (:mod:`mrnea.identify`): a missing
    column, a bad number, NaN, time that does not increase. The message names the file and the
    row."""


class SizingError(MrneaError):
    """Drive sizing cannot start: its catalogue file (the message names the entry and field at
    fault), a joint it was asked to size, an objective or an option."""


class ModelWarning(UserWarning):
    """A robot description is valid but physically doubtful (an inertia that violates the
    triangle inequality, a massless moving link); mrnea goes on and says so."""


class PathWarning(UserWarning):
    """A commanded path is valid but doubtful: its interpolation between a CSV's rows leaves a
    position limit the rows respect (the simulator would clamp it), or its rows look like
    degrees; mrnea goes on and says so. ``cli``: the message as the command line says it (as
    :class:`MrneaError`'s), None: the same for both."""

    def __init__(self, message: str, cli: str | None = None) -> None:
        super().__init__(message)
        self.cli = cli


class MeshWarning(UserWarning):
    """Mesh files of a robot's visuals could not be drawn (not found, unreadable); the view
    draws those links as capsules. ``hint``: how to point mrnea at them (None: no hint), which
    the command line prints on a line of its own."""

    def __init__(self, message: str, hint: str | None = None) -> None:
        super().__init__(message)
        self.hint = hint

