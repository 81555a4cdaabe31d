"""What every reader does first: read an input file safely, and read numbers strictly.

Files (:func:`read_bytes`, :func:`read_text`). Every file mrnea reads (robot files, sidecar
actuator files, programs, path CSVs) must be a regular file of at most a given size. The file is
looked at with :func:`os.stat` before it is opened, and opened with ``O_NONBLOCK``, so a FIFO
never blocks the reader and a device (``/dev/zero``, ``/dev/random``) is refused instead of read
until memory runs out; the size is checked again on the open file, and at most the limit plus
one byte is ever read.

XML (:func:`refused_prolog`): a document whose prolog has a DTD with declarations (entities) is
refused before any parser expands them.

Numbers (:func:`parse_number`): one grammar for every number written as text (URDF attributes,
CSV cells, the command line's options), ASCII decimal or scientific notation::

    number   = [sign] (digits ["." [digits]] | "." digits) [("e" | "E") [sign] digits]
    sign     = "+" | "-"
    digits   = one or more of 0 1 2 3 4 5 6 7 8 9

Where a limit may be unbounded, ``inf``, ``+inf`` or ``-inf`` (lower case) are read as
infinities. Nothing else is a number: not Python's ``1_000``, non-ASCII digits, ``nan``,
``Infinity``, hexadecimal, spaces inside or around (readers strip their own separators), or a
value too large for a double (``1e999``).
"""

from __future__ import annotations

import errno
import os
import re
import stat
from collections.abc import Callable, Iterator
from itertools import islice
from pathlib import Path
from xml.parsers import expat

from mrnea.errors import MrneaError, quote

__all__ = ["MAX_CSV_SIZE", "MAX_FILE_SIZE", "after_line", "as_path", "expand_home", "line_blocks",
           "parse_number", "read_bytes", "read_text", "refused_prolog", "text_lines"]

MAX_FILE_SIZE = 16 * 2**20
"""Largest robot, sidecar or program file read (16 MiB: a 1000-joint robot in TOML is 0.2 MB)."""
MAX_CSV_SIZE = 2**30
"""Largest path CSV read (1 GiB; reading one also needs memory, checked against the budget)."""

_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INFINITY = {"inf": float("inf"), "+inf": float("inf"), "-inf": float("-inf")}


def as_path(value: object, name: str, error: type[MrneaError]) -> Path:
    """``value`` as a :class:`~pathlib.Path`: a non-empty ``str`` or ``os.PathLike`` of text.

    Raises ``error`` naming the argument ``name`` for anything else (None, a number, bytes...).
    """
    if isinstance(value, (str, os.PathLike)):
        try:
            p = Path(value)
        except TypeError:  # a PathLike whose path is bytes
            pass
        else:
            if "\0" in str(p):  # no file system takes it (os.stat: "embedded null byte");
                # quoted as text: a Path's repr (PosixPath('...')) is not what the user wrote
                raise error(f"{name}: a file path cannot hold a NUL character, got {quote(str(p))}")
            if str(value):
                return p
            raise error(f"{name}: expected a file path, got an empty string")
    raise error(f"{name}: expected a file path (str or os.PathLike), got "
                f"{type(value).__name__} {quote(value)}")


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def _size_text(n: int) -> str:
    return f"{n / 2**20:.3g} MiB" if n >= 2**20 else f"{n} bytes"


def read_bytes(path: str | os.PathLike[str], what: str, error: type[MrneaError],
               max_size: int = MAX_FILE_SIZE) -> bytes:
    """The content of a regular file of at most ``max_size`` bytes.

    Parameters
    ----------
    path : the file.
    what : what the file is, for messages (``"robot file"``, ``"path CSV file"``).
    error : the error type raised, naming the file.
    max_size : the largest size accepted [bytes].

    Raises
    ------
    error
        Missing or unreadable file, a directory, FIFO, device or socket, a file larger than
        ``max_size``.
    """
    p = as_path(path, "path", error)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise error(f"{p}: {what} not found") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the path
        raise error(f"{p}: cannot read {what}: {getattr(exc, 'strerror', None) or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{p}: cannot read {what}: it is {_kind(st.st_mode)}, not a regular file")
    too_big = error(f"{p}: {what} is too large ({_size_text(st.st_size)}; at most "
                    f"{_size_text(max_size)} is read)")
    if st.st_size > max_size:
        raise too_big
    try:
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        raise error(f"{p}: cannot read {what}: {exc.strerror}") from None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):  # replaced between the stat and the open
            raise error(f"{p}: cannot read {what}: not a regular file")
        chunks, total = [], 0
        while total <= max_size:
            chunk = os.read(fd, min(2**20, max_size + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
    except OSError as exc:
        if exc.errno == errno.EISDIR:
            raise error(f"{p}: cannot read {what}: it is a directory") from None
        raise error(f"{p}: cannot read {what}: {exc.strerror}") from None
    finally:
        os.close(fd)
    if total > max_size:  # it grew after the stat
        raise too_big
    return b"".join(chunks)


def read_text(path: str | os.PathLike[str], what: str, error: type[MrneaError],
              max_size: int = MAX_FILE_SIZE) -> str:
    """The text of a UTF-8 file read by :func:`read_bytes` (a byte-order mark is not an error).

    Raises ``error`` naming the file and ``what`` it is (``"robot file"``, ...).
    """
    data = read_bytes(path, what, error, max_size)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise error(f"{path}: cannot read {what}: not UTF-8 text (byte "
                    f"{quote(data[exc.start:exc.start + 1])} at line {line})") from None


def expand_home(path: Path, fail: Callable[[str], MrneaError]) -> Path:
    """``path`` with a leading ``~`` or ``~user`` expanded (:meth:`pathlib.Path.expanduser`);
    ``fail(message)`` raised where it cannot be: an unknown user or no home directory, for
    which ``expanduser`` raises RuntimeError (it reached the command line as an internal
    error)."""
    try:
        return path.expanduser()
    except RuntimeError:
        raise fail(f"cannot expand '~' in {quote(str(path))} (no such user, or no home "
                   f"directory)") from None


_LINE_END = re.compile(r"\r\n?|\n")


def text_lines(text: str, pos: int = 0) -> Iterator[str]:
    """The lines of ``text[pos:]`` one by one, each ended by LF, CRLF or a lone CR (an old Mac
    file) and by nothing else: ``str.splitlines`` also ends a line at a form feed, a vertical
    tab, U+001C..U+001E, U+0085, U+2028 and U+2029, which made a comment's rest a data row,
    read a row holding such a character as two, and shifted every later line number from an
    editor's. One by one: a list of a short-rowed file's lines takes 16 bytes per byte of it,
    beyond the reading's memory budget (:mod:`mrnea.resources`)."""
    for end in _LINE_END.finditer(text, pos):
        yield text[pos:end.start()]
        pos = end.end()
    if pos < len(text):
        yield text[pos:]


def after_line(text: str, line: int) -> int | None:
    """The offset in ``text`` just past line ``line``'s end (1-based; line ends as in
    :func:`text_lines`), or None where that line has no end (the last line, or beyond)."""
    end = next(islice(_LINE_END.finditer(text), line - 1, None), None)
    return None if end is None else end.end()


def line_blocks(text: str, pos: int = 0, size: int = 2**20) -> Iterator[list[str]]:
    """The lines of ``text[pos:]`` (as :func:`text_lines`) as lists of about ``size`` characters of
    them: a fast reader splits a block at once, and never holds a list of every line."""
    while pos < len(text):
        end = _LINE_END.search(text, min(pos + size, len(text)))  # a block ends a line
        stop = len(text) if end is None else end.end()
        block = text[pos:stop]
        if "\r" in block:
            block = block.replace("\r\n", "\n").replace("\r", "\n")
        yield block.split("\n")[:-1] if block.endswith("\n") else block.split("\n")
        pos = stop


#: A character outside what Python's ``float`` and :func:`parse_number` read alike
_BEYOND_GRAMMAR = re.compile(r"[^\x20-\x7e\t\r\n]|_")


def float_reads_grammar(text: str, pos: int = 0) -> bool:
    """Whether Python's ``float`` reads each cell of ``text[pos:]`` as :func:`parse_number` does
    (a reader's fast path: many cells through ``float``, the odd file through the grammar):
    where the text holds nothing but printable ASCII, tabs and line ends, and no underscore
    (``float``'s extras: ``1_000``, non-ASCII digits, other whitespace). ``float`` still reads
    ``nan``, ``inf`` and ``infinity``, which such a caller refuses as non-finite numbers."""
    return _BEYOND_GRAMMAR.search(text, pos) is None


def parse_number(text: str, allow_inf: bool = False) -> float:
    """The number ``text`` spells in the grammar of the module docstring.

    Parameters
    ----------
    text : the number, without surrounding spaces.
    allow_inf : accept ``inf``, ``+inf``, ``-inf`` (a limit that may be unbounded).

    Returns
    -------
    float

    Raises
    ------
    ValueError
        Not in the grammar, an infinity where none is allowed, or too large for a double; the
        message says which and quotes ``text`` (shortened).
    """
    if not isinstance(text, str):
        raise ValueError(f"expected a number as text, got {type(text).__name__}")
    if _NUMBER.fullmatch(text):
        value = float(text)
        if value in (float("inf"), float("-inf")):
            raise ValueError(f"{quote(text)} is out of range (too large for a double)")
        return value
    if text in _INFINITY and allow_inf:
        return _INFINITY[text]
    if text.strip().lower().lstrip("+-") in ("nan", "inf", "infinity"):
        raise ValueError(f"{quote(text)} is not a finite number"
                         + (" (an unbounded limit is written inf)" if allow_inf else ""))
    raise ValueError(f"not a number: {quote(text)} (numbers are written in ASCII decimal or "
                     "scientific notation, e.g. 1.5, -2, 3e-4)")


class _Declaration(Exception):
    """Raised inside expat's handlers: the document has a DTD with declarations."""


class _RootReached(Exception):
    """Raised inside expat's handlers: the prolog (where a DTD can be) is over."""


def refused_prolog(data: bytes) -> str | None:
    """Why an XML document's prolog is refused (None: it is not): URDF needs no DTD, and the
    declarations of an internal subset are what lets a small file expand into a huge one
    (entities) or read other files (external entities). Expat reads the prolog only: it stops
    at the root element. A document in an encoding expat does not know (ElementTree decodes
    those through Python's codecs) is searched for the declarations' ASCII spelling instead."""
    parser = expat.ParserCreate()

    def doctype(name: str, sysid: str | None, pubid: str | None, internal: int) -> None:
        if internal:
            raise _Declaration("it has a DOCTYPE with an internal subset (declarations)")

    def entity(*args: object) -> None:
        raise _Declaration("it declares entities")

    def root(*args: object) -> None:
        raise _RootReached

    parser.StartDoctypeDeclHandler = doctype
    parser.EntityDeclHandler = entity
    parser.UnparsedEntityDeclHandler = entity
    parser.StartElementHandler = root
    try:
        parser.Parse(data, True)
    except _Declaration as exc:
        return f"{exc} at line {parser.CurrentLineNumber}"
    except _RootReached:
        return None
    except (expat.ExpatError, LookupError, ValueError):  # the XML parser reports these
        if re.search(rb"<!\s*(ENTITY|DOCTYPE[^>]*\[)", data):
            return "it declares entities or has a DOCTYPE with an internal subset"
    return None
