"""The one way mrnea writes a file: whole or not at all, never through a link, never over a file
it was not allowed to replace.

Every output the package writes (the per-cycle table, ``summary.json``, figures, the HTML report,
URDF exports) goes through :func:`create`:

* the data go to a private temporary file in the destination's folder (an unpredictable name,
  opened with ``O_CREAT | O_EXCL | O_NOFOLLOW``, so a link planted in the folder is never
  followed), which is renamed into place when the block ends without an exception;
* without ``overwrite`` the file is published by a hard link, which fails if anything exists
  at the destination, a dangling symbolic link included: an existing file is never replaced,
  not even by a second run that checked at the same instant;
* with ``overwrite`` the destination is replaced by :func:`os.replace`, which replaces a
  symbolic link itself, never the file it points to;
* a destination that is a directory is an error, with or without ``overwrite``;
* on any exception (KeyboardInterrupt included) the temporary file is removed;
* the file gets the mode :func:`open` would give it (``0o666`` less the umask).

:func:`check_new` refuses the same destinations before any work is done, and
:func:`own_folder` makes a run the only writer of its output folder. Every failure is an
:class:`~mrnea.errors.OutputError` naming the path. POSIX only (``O_NOFOLLOW``, ``flock``).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import io
import os
import secrets
import stat
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from mrnea.errors import OutputError, quote
from mrnea.io.source import as_path

LOCK_NAME = ".mrnea.lock"
"""The lock file :func:`own_folder` keeps in an output folder while a run writes there."""

_FLAGS = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
_NO_HARD_LINKS = {errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EMLINK, errno.ENOSYS}


def _refusal(path: Path, overwrite: bool) -> OutputError | None:
    """Why ``path`` may not be written (None if it may), in the library's words and the
    command line's (:class:`~mrnea.errors.MrneaError` ``cli``)."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        return OutputError(f"{path}: cannot write: {exc.strerror}")
    if stat.S_ISDIR(st.st_mode):
        return OutputError(f"{path} is a directory; name a file to write")
    if overwrite:
        return None
    what = f"{path} exists" + (" (a symbolic link)" if stat.S_ISLNK(st.st_mode) else "")
    return OutputError(f"{what}; pass overwrite=True to replace it",
                       cli=f"{what}; add --force to replace it")


def check_new(paths: Iterable[str | os.PathLike[str]], overwrite: bool = False) -> None:
    """Refuse, before any work, the first of ``paths`` that :func:`create` would refuse.

    Raises
    ------
    OutputError
        A path is a directory, or exists (a symbolic link, dangling or not, included) and
        ``overwrite`` is False.
    """
    overwrite = _flag(overwrite)
    if isinstance(paths, (str, bytes, os.PathLike)):
        raise OutputError(f"paths: expected a list of file paths, got one: {quote(paths)}")
    for p in paths:
        refusal = _refusal(as_path(p, "path", OutputError), overwrite)
        if refusal:
            raise refusal


@contextlib.contextmanager
def create(path: str | os.PathLike[str], overwrite: bool = False, *,
           binary: bool = False) -> Iterator[IO[Any]]:
    """Open a new file for writing at ``path``; it appears there, whole, when the block ends.

    Parameters
    ----------
    path : str or path-like
        The file to write. Its folder must exist.
    overwrite : bool, default False
        Replace an existing file or symbolic link at ``path`` (the link itself, never its
        target). Without it anything existing at ``path`` is left untouched and the call fails.
    binary : bool, default False
        Yield a binary file object; otherwise a UTF-8 text one (no newline translation).

    Yields
    ------
    file object
        Writing to a private temporary file in ``path``'s folder. If the block raises, the
        temporary file is removed and ``path`` is left as it was.

    Raises
    ------
    OutputError
        ``path`` is a directory, exists without ``overwrite``, or cannot be written (folder
        missing, permission, disk full...).
    """
    path = as_path(path, "path", OutputError)
    overwrite = _flag(overwrite)
    check_new([path], overwrite)
    tmp = path.with_name(f".{path.name[:40]}.{secrets.token_hex(8)}.tmp")
    try:
        fd = os.open(tmp, _FLAGS, 0o666)  # the umask applies, as with open()
    except OSError as exc:
        raise OutputError(f"{path}: cannot write: {exc.strerror}") from None
    try:
        raw = os.fdopen(fd, "wb")
        fh = raw if binary else io.TextIOWrapper(raw, encoding="utf-8", newline="")
        with fh:
            yield fh
            fh.flush()
            os.fsync(fd)
        _publish(tmp, path, overwrite)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write: {exc.strerror or exc}") from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


def write_file(path: str | os.PathLike[str], data: str | bytes, overwrite: bool = False) -> Path:
    """Write ``data`` (``str``: as UTF-8) to ``path`` through :func:`create`, whole or not at
    all; returns ``path`` as a Path. Raises OutputError as :func:`create` does."""
    path = as_path(path, "path", OutputError)
    with create(path, overwrite, binary=isinstance(data, bytes)) as fh:
        fh.write(data)
    return path


@contextlib.contextmanager
def all_or_none(paths: Iterable[str | os.PathLike[str]], overwrite: bool = False, *,
                keep_on_interrupt: bool = False) -> Iterator[None]:
    """The files the block writes at ``paths`` (a run's outputs): all of them, or none.

    With ``overwrite`` each regular file already at one of ``paths`` is first moved aside in its
    folder (``.NAME.mrnea-old``). If the block raises, every one of ``paths`` that was not there
    before it is removed and the files moved aside are put back as they were; once the block
    ends, they are deleted. ``keep_on_interrupt``: a KeyboardInterrupt (a stop request) keeps
    the files written when none was moved aside (they are whole, and the only ones of this kind
    there).

    Something already at a ``.NAME.mrnea-old`` name (the old file of a run that was killed, or a
    user's file) is refused rather than replaced, and a file that cannot be moved aside is an
    error rather than replaced without a copy: either way it could not be put back.
    """
    overwrite = _flag(overwrite)
    targets = list(dict.fromkeys(as_path(p, "path", OutputError) for p in paths))
    kept: list[tuple[Path, Path]] = []  # (the file, its old content moved aside)
    try:
        for path in targets if overwrite else ():
            if stat.S_ISREG(_lstat_mode(path)):
                kept.append((path, _move_aside(path)))
    except BaseException:
        _put_back(kept)
        raise
    there = {path for path in targets if _lstat_mode(path)}  # not this block's to remove
    try:
        yield
    except BaseException as exc:
        if not (keep_on_interrupt and not kept and isinstance(exc, KeyboardInterrupt)):
            for path in targets:
                if path not in there:
                    with contextlib.suppress(OSError):
                        os.unlink(path)
            _put_back(kept)
        raise
    for _, old in kept:
        with contextlib.suppress(OSError):
            os.unlink(old)


def _move_aside(path: Path) -> Path:
    """Move the file ``path`` to ``.NAME.mrnea-old`` in its folder (for :func:`all_or_none`);
    returns that path. An OutputError, ``path`` untouched, if anything is there already."""
    old = path.with_name(f".{path.name}.mrnea-old")
    if os.path.lexists(old):
        raise OutputError(f"{old} exists (the old {path.name} of a run that was stopped?); move "
                          f"or remove it before replacing {path}")
    try:
        os.replace(path, old)
    except OSError as exc:
        raise OutputError(f"{path}: cannot move it aside to replace it: {exc.strerror}") from None
    return old


def _put_back(kept: list[tuple[Path, Path]]) -> None:
    """The files :func:`all_or_none` moved aside, back at their names."""
    for path, old in kept:
        with contextlib.suppress(OSError):
            os.replace(old, path)


def _lstat_mode(path: Path) -> int:
    try:
        return os.lstat(path).st_mode
    except OSError:
        return 0


def _flag(value: object, name: str = "overwrite") -> bool:
    """``value`` if it is a boolean (Python's or NumPy's); an OutputError naming ``name``
    otherwise (a string such as ``"no"`` is true, so none is taken for one)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise OutputError(f"{name}: expected True or False, got {type(value).__name__} "
                      f"{quote(value)}")


def _publish(tmp: Path, path: Path, overwrite: bool) -> None:
    """Move the finished temporary file to ``path`` (see the module docstring)."""
    if overwrite:
        refusal = _refusal(path, True)  # a directory may have appeared meanwhile
        if refusal:
            raise refusal
        os.replace(tmp, path)
        return
    try:
        os.link(tmp, path, follow_symlinks=False)  # fails if anything is at path
    except FileExistsError:
        raise (_refusal(path, False) or OutputError(f"{path} exists")) from None
    except OSError as exc:
        if exc.errno not in _NO_HARD_LINKS:
            raise
        # a file system without hard links: check, then rename (not atomic against a
        # second writer, which own_folder excludes for a run's outputs)
        check_new([path])
        os.rename(tmp, path)


@contextlib.contextmanager
def own_folder(folder: str | os.PathLike[str]) -> Iterator[Path]:
    """Make this process the only mrnea run writing into ``folder`` (created if missing).

    An exclusive ``flock`` on ``folder/.mrnea.lock`` (opened without following a link) is held
    for the block and the lock file removed at its end. The kernel releases the lock when a
    process dies, so a run that was killed never blocks the next one (its lock file stays
    behind, harmless). A folder this call created is removed again if the block fails before
    writing anything into it (a bad program leaves no empty folder behind).

    ``folder`` itself must not be a symbolic link (checked before and after creating it): the
    files of a run are never written through a link, a planted one at a default folder's name
    included.

    Raises
    ------
    OutputError
        ``folder`` is a symbolic link, cannot be created, or another run holds it.
    """
    folder = as_path(folder, "folder", OutputError)
    created = not os.path.lexists(folder)
    _refuse_link(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:  # folder, or a folder above it, is something else
        raise OutputError(_not_a_folder(folder)) from None
    except OSError as exc:
        raise OutputError(f"{folder}: cannot create the output folder: {exc.strerror}") from None
    _refuse_link(folder)  # a link planted between the check and mkdir
    lock = folder / LOCK_NAME
    fd = _lock(folder, lock)
    failed = True
    try:
        yield folder
        failed = False
    finally:
        with contextlib.suppress(OSError):
            os.unlink(lock)  # while still holding it: see _lock
        os.close(fd)
        if failed and created:
            with contextlib.suppress(OSError):
                folder.rmdir()  # only if empty: nothing written, nothing lost


def _not_a_folder(folder: Path) -> str:
    """Why ``folder`` cannot be created when something exists in its way: itself, or a folder
    above it that is a file or a dangling symbolic link (``mkdir -p`` says only that a file
    exists, and ``LINK/out`` was said to exist when it was ``LINK`` that did)."""
    for p in reversed(folder.parents):
        if os.path.lexists(p) and not os.path.isdir(p):
            what = "a dangling symbolic link" if os.path.islink(p) else "not a folder"
            return f"{folder}: cannot create the output folder: {p} is {what}"
    return f"{folder} exists and is not a folder"


def _refuse_link(folder: Path) -> None:
    """An OutputError if ``folder`` (its last component) is a symbolic link: an output folder is
    never written through one, whether the user named it or it is a command's default."""
    if os.path.islink(folder):
        try:
            target = f" (to {quote(os.readlink(folder))})"
        except OSError:
            target = ""
        raise OutputError(f"{folder} is a symbolic link{target}; mrnea never writes through a "
                          "link: name a real folder (the link's target itself, if that is meant)")


def _lock(folder: Path, lock: Path) -> int:
    """Open and lock ``lock``; retry if its holder removed it between our open and our lock."""
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC
                         | os.O_NONBLOCK, 0o666)
        except OSError as exc:
            raise OutputError(f"{folder}: cannot lock the output folder ({lock.name}: "
                              f"{exc.strerror})") from None
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise OutputError(f"{folder}: cannot lock the output folder ({lock.name} is not "
                                  "a regular file)")
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            same = os.path.samestat(os.fstat(fd), os.lstat(lock))
        except BlockingIOError:
            os.close(fd)
            raise OutputError(f"{folder}: another mrnea run is writing into this folder") from None
        except FileNotFoundError:
            same = False
        except BaseException:
            os.close(fd)
            raise
        if same:
            return fd
        os.close(fd)
