"""Path CSV files: a recorded or externally planned path (time, q1..qn), resampled to the cycle dt.

The layout is in :func:`from_csv` and ``docs/programs.md``; a program file may name such a file
(:mod:`mrnea.io.program`). The cycle grid is :func:`mrnea.trajectory.cycles`, the same as the
waypoint profiles'. The rows are interpolated by a spline (:data:`INTERPOLATIONS`, default
cubic) or linearly; :func:`limit_warnings` says where the interpolant leaves a position limit
that the rows respect.

Why a spline by default: between rows, linear interpolation has a constant velocity that jumps
at every row, so the acceleration the simulator asks for (the second difference of the
commanded positions) spikes there. ``sin(pi t)`` sampled every 50 ms and resampled at 5 ms
peaks at 98.5 rad/s^2 linearly, against 9.87 rad/s^2 for the path itself; the cubic spline
gives 9.89, the quintic 9.87 (tests/test_pathcsv.py). A spline's end conditions are the path's
own: where a joint starts (ends) at rest -- its first (last) two rows are equal -- its velocity
there is zero (the quintic: velocity and acceleration), else "not-a-knot" (the first two
polynomial pieces are one, so nothing is imposed). A natural spline's zero end acceleration
would be invented where the path accelerates. scipy is imported on the first spline
(``scipy.interpolate`` takes about 0.4 s to import; a linear resampling does not need it).
"""

from __future__ import annotations

import csv
import io
import os
import warnings
from array import array
from collections.abc import Sequence
from itertools import chain, islice
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import PathWarning, ProgramFileError, StateError, quote
from mrnea.io.jointnames import CsvHeader, column_order
from mrnea.io.source import (
    MAX_CSV_SIZE,
    after_line,
    as_path,
    float_reads_grammar,
    line_blocks,
    parse_number,
    read_text,
    text_lines,
)
from mrnea.io.writer import create
from mrnea.model import Robot
from mrnea.resources import format_bytes, require_memory
from mrnea.trajectory import cycles, require_path_memory
from mrnea.validate import choice, time_step

__all__ = ["CSV_UNITS", "DELIMITERS", "INTERPOLATIONS", "data_lines", "from_csv",
           "limit_warnings", "read_table", "resample", "save_csv"]

#: The interpolations of a path CSV's rows, by name, and what each one is (the report says it).
INTERPOLATIONS = {
    "cubic": "cubic spline (C2; not-a-knot ends, zero velocity where the path starts or ends "
             "at rest)",
    "quintic": "quintic spline (C4; not-a-knot ends, zero velocity and acceleration where the "
               "path starts or ends at rest)",
    "linear": "linear between the rows (the velocity jumps at every row)",
}


#: The units of a path CSV's joint columns: SI, or degrees (revolute) and mm (prismatic).
CSV_UNITS = {"rad": "rad for revolute joints, m for prismatic ones (SI)",
             "deg": "degrees for revolute joints, mm for prismatic ones"}
#: The column delimiters a path CSV may use, by name; the header row says which (the first of
#: comma, semicolon, tab it holds, else runs of spaces).
DELIMITERS = {",": "comma", ";": "semicolon", "\t": "tab", " ": "spaces"}


def _delimiter(line: str) -> str:
    """The delimiter of a header row (:data:`DELIMITERS`)."""
    for d in (",", ";", "\t"):
        if d in line:
            return d
    return " "


def _rows(text: str):
    """(line number, cells) of every line of a path CSV, split at the header row's delimiter
    (a controller's log: space-, tab- or semicolon-separated); the delimiter is yielded first."""
    delimiter = None
    for number, raw in enumerate(text_lines(text), start=1):
        line = raw.strip(" \t\r")
        if not line or line.startswith("#"):
            continue
        if delimiter is None:
            delimiter = _delimiter(line)
            yield delimiter
        if delimiter == " ":
            yield number, line.split()
        else:
            try:
                cells = next(csv.reader([line], delimiter=delimiter))
            except csv.Error as exc:  # a cell over csv's field limit: name the line
                raise csv.Error(f"line {number}: not valid CSV: {exc}") from None
            yield number, [c.strip(" \t") for c in cells]


def data_lines(path: Path) -> list[int]:
    """The line numbers (1-based) of a path CSV's header and data rows, in order: the lines
    :func:`read_table` reads (not blank, not a ``#`` comment). For messages about a row that
    :func:`read_table` has returned."""
    text = read_text(path, "path CSV file", ProgramFileError, MAX_CSV_SIZE)
    return [number for number, raw in enumerate(chain.from_iterable(line_blocks(text)), start=1)
            if (line := raw.strip(" \t\r")) and not line.startswith("#")]


def read_table(path: Path, n: int | None) -> tuple[CsvHeader, NDArray[np.float64]]:
    """Header and (R, 1 + n) numeric rows of a path CSV, every cell checked.

    The columns are separated by the header row's delimiter: a comma, else a semicolon, else a
    tab, else runs of spaces (:data:`DELIMITERS`); every row must use it.

    Parameters
    ----------
    path : the ``.csv`` file: a regular file of at most :data:`mrnea.io.source.MAX_CSV_SIZE`
        bytes, whose reading fits the memory budget (:mod:`mrnea.resources`).
    n : expected number of joint columns; None: any (at least one).

    Returns
    -------
    header : the column names, the file and the header's line.
    rows : (R, 1 + n) time [s] and joint positions, R >= 2, time strictly increasing.

    Raises
    ------
    ProgramFileError
        Naming the file, the line (data row) and the column at fault.
    """
    try:
        size = os.stat(path).st_size
    except (OSError, ValueError):
        size = 0  # read_text says what is wrong with the file
    # the text (up to 4 bytes a character) and the numbers (8 bytes for a cell of >= 2 bytes);
    # a file over the size limit is read_text's to refuse, whatever the memory
    if size <= MAX_CSV_SIZE:
        require_memory(9 * size, f"{path}: reading this {format_bytes(size)} path CSV file",
                       "resample it more coarsely or split it", ProgramFileError)
    text = read_text(path, "path CSV file", ProgramFileError, MAX_CSV_SIZE)
    header: list[str] | None = None
    header_line = 0
    values = array("d")
    rows = last_time = 0
    lines = _rows(text)
    delimiter = next(lines, ",")
    try:
        for line, cells in lines:
            if header is None:
                header, header_line = cells, line
                _check_header(path, line, header, n, delimiter)
                plain = _plain_rows(text, header_line, delimiter, len(header))
                if plain is not None:  # every row read at once; else row by row, below
                    rows = len(plain)
                    if rows < 2:  # what the rows below would say, without reading them again
                        break
                    return CsvHeader(tuple(header), str(path), header_line), plain
                continue
            if len(cells) != len(header):
                raw = next(islice(text_lines(text), line - 1, None))
                found = [name for d, name in DELIMITERS.items()
                         if d != delimiter and d != " " and d in raw]
                raise ProgramFileError(
                    f"{path}: line {line} (data row {rows + 1}): expected {len(header)} "
                    f"columns separated by {DELIMITERS[delimiter]} as in the header (line "
                    f"{header_line}), got {len(cells)}"
                    + (f" (the row has a {found[0]}: one delimiter for the whole file)"
                       if found else ""))
            for col, cell in enumerate(cells):
                try:
                    v = parse_number(cell)
                except ValueError as exc:
                    where = (f"{path}: line {line} (data row {rows + 1}), column {col + 1} "
                             f"({quote(header[col])})")
                    # a decimal comma under a semicolon header, or a header and rows that
                    # disagree: name the delimiter expected and the one the cell holds
                    held = [name for d, name in DELIMITERS.items()
                            if d != delimiter and d != " " and d in cell]
                    hint = (f" (the cell holds a {held[0]}; columns are separated by "
                            f"{DELIMITERS[delimiter]} as in the header (line {header_line}), and "
                            "numbers use a decimal point)" if held else "")
                    raise ProgramFileError(f"{where}: {exc}{hint}" if cell
                                           else f"{where}: empty cell") from None
                if col == 0 and rows and v <= last_time:
                    raise ProgramFileError(
                        f"{path}: line {line} (data row {rows + 1}), column 1 "
                        f"({quote(header[0])}): time {v!r} s is not greater than the previous "
                        f"row's {last_time!r} s (time must be strictly increasing)")
                values.append(v)
            last_time = values[-len(cells)]
            rows += 1
    except csv.Error as exc:
        raise ProgramFileError(f"{path}: {exc}") from None
    if header is None:
        raise ProgramFileError(f"{path}: empty file: expected a header row (time, then one column "
                               "per joint) and at least two data rows")
    if rows < 2:
        raise ProgramFileError(f"{path}: {rows} data row(s) after the header: a path needs "
                               "at least two (time strictly increasing)")
    return (CsvHeader(tuple(header), str(path), header_line),
            np.frombuffer(values, dtype=np.float64).reshape(rows, len(header)).copy())


def _plain_rows(text: str, header_line: int, delimiter: str, columns: int
                ) -> NDArray[np.float64] | None:
    """The rows after the header (line ``header_line``) of a plain path CSV, read at once: each
    of ``columns`` numbers, finite, time strictly increasing (maybe fewer than two). None where any
    of that fails, or ``float`` could read a cell the grammar does not
    (:func:`~mrnea.io.source.float_reads_grammar`): :func:`read_table` then reads row by row and
    names the line and the column at fault. Both ways read the same numbers; this one about
    ten times faster (a million rows in seconds). Comment lines and line ends of every kind
    (:func:`~mrnea.io.source.text_lines`) are read here too: either sent a million rows row by row
    (18 s, not 6)."""
    end = after_line(text, header_line)
    if end is None or not float_reads_grammar(text, end):  # past the header's line end
        return None
    values = array("d")
    rows = 0
    try:
        for block in line_blocks(text, end):
            for line in filter(None, block):  # blank lines at once (a file of them)
                if (kept := line.strip(" \t")) and not kept.startswith("#"):  # as _rows skips
                    cells = line.split() if delimiter == " " else line.split(delimiter)
                    if len(cells) != columns:
                        return None
                    values.extend(map(float, cells))
                    rows += 1
    except ValueError:  # an empty cell, "1e", "+-1", a word, a comment: not the grammar's
        return None
    data = np.frombuffer(values, dtype=np.float64).reshape(rows, columns)
    if not np.isfinite(data).all() or not (np.diff(data[:, 0]) > 0).all():
        return None
    return data.copy()


def _check_header(path: Path, line: int, header: list[str], n: int | None,
                  delimiter: str = ",") -> None:
    """The header row's shape (its text is never quoted: the file may not be a CSV at all)."""
    if len(header) < 2:
        raise ProgramFileError(
            f"{path}: line {line}: the header row needs a time column and at least one "
            f"joint column, got {len(header)} column: expected the columns separated by a "
            "comma, a semicolon, a tab or spaces (is this a path CSV file?)")
    if n is not None and len(header) != n + 1:
        raise ProgramFileError(
            f"{path}: line {line}: expected {n + 1} columns (time + {n} joints), the "
            f"header row has {len(header)}")
    try:
        parse_number(header[0])
    except ValueError:
        return
    raise ProgramFileError(f"{path}: line {line}: the first row must be a header (e.g. "
                           "t,q1,q2,...), got numbers")


def from_csv(
    path: str | Path,
    dt: float,
    n: int | None = None,
    interpolation: str = "cubic",
    robot: Robot | None = None,
    units: str = "rad",
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Read a path CSV (time, q1..qn) and resample it to the interpolation cycle dt.

    File layout: one header row (column names, free text), then one row per sample: time [s]
    (strictly increasing, need not be uniform) and n joint positions [rad | m], or with
    ``units="deg"`` [deg | mm]. The columns are separated by commas, semicolons, tabs or spaces
    (the header row's, :func:`read_table`). Cells may be padded with spaces; blank lines and
    lines whose first cell starts with ``#`` are ignored.

    The rows are interpolated at ``t[k] = t_first + k dt`` from the first row's time to the
    last's (:func:`resample`): by default a cubic spline through every row, with the path's own
    end conditions (module docstring), so that rows coarser than dt do not turn into
    acceleration spikes; ``"linear"`` never leaves the range of the rows but its acceleration
    spikes at every row. If the time span is not a whole number of cycles, the last cycle falls
    after the last row and holds its position: the last commanded row always equals the CSV's
    last row, and the first the first.

    Parameters
    ----------
    path : the ``.csv`` file.
    dt : interpolation cycle [s], finite and > 0.
    n : expected number of joints (columns after the time column); None: any, from the header
        (or ``robot.n``).
        A header that names the robot's joints is matched by name, in any order
        (:func:`mrnea.io.jointnames.column_order`); ``q`` is in the robot's joint order.
    interpolation : ``"cubic"`` (default), ``"quintic"`` or ``"linear"`` (:data:`INTERPOLATIONS`).
    robot : the robot the path is for: its joint count is expected, and a
        :class:`mrnea.errors.PathWarning` names each joint whose interpolated path leaves the
        robot's position limits while the rows stay within them (:func:`limit_warnings`), or
        says that rows in rad that start outside the limits look like degrees.
    units : ``"rad"`` (default: SI, rad or m) or ``"deg"``: the joint columns in degrees, and
        with ``robot`` a prismatic joint's in mm (:data:`CSV_UNITS`; without ``robot`` every
        column is taken as degrees).

    Returns
    -------
    t : (K,) cycle times ``t_first + k dt`` [s], K >= 2.
    q : (K, n) commanded positions [rad | m].

    Raises
    ------
    ProgramFileError
        Missing or empty file, wrong column count, non-numeric / empty / NaN / inf cell, time not
        strictly increasing, fewer than two data rows (a quintic spline: see :func:`resample`);
        the message names the file, the line (data row) and the column.
    StateError
        Bad ``dt``, ``n``, ``interpolation`` or ``robot``.
    """
    dt = time_step(dt)
    choice("interpolation", interpolation, INTERPOLATIONS)
    choice("units", units, CSV_UNITS)
    if robot is not None:
        if not isinstance(robot, Robot):
            raise StateError(f"robot: expected a mrnea.Robot or None, got {robot!r}")
        if n is not None and n != robot.n:
            raise StateError(f"n: {n!r} joints, but robot '{robot.name}' has {robot.n}")
        n = robot.n
    if n is not None and (isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1):
        raise StateError(f"n: expected a number of joints >= 1 or None, got {n!r}")
    p = as_path(path, "path", ProgramFileError)
    header, data = read_table(p, None if n is None or robot is not None else int(n))
    if robot is not None:
        order = column_order(header, robot, units)
        if order is not None:
            data = data[:, np.r_[0, order]]
        elif data.shape[1] != n + 1:
            raise ProgramFileError(f"{p}: line {header.line}: expected {n + 1} columns (time + "
                                   f"{n} joints), the header row has {data.shape[1]}, and it "
                                   f"names none of robot {quote(robot.name)}'s joints")
    if units == "deg":
        prismatic = np.zeros(data.shape[1] - 1, dtype=bool) if robot is None else robot.is_prismatic
        data[:, 1:] *= np.where(prismatic, 1e-3, np.pi / 180.0)
    elif robot is not None:
        degree_hint(robot, data, str(p))
    try:
        t, q = resample(data[:, 0], data[:, 1:], dt, interpolation, str(p))
    except StateError as exc:  # too many cycles for dt
        raise ProgramFileError(f"{p}: {exc}") from None
    if robot is not None:
        limit_warnings(robot, t, q, data, interpolation, str(p))
    return t, q


def resample(time: NDArray, q: NDArray, dt: float, interpolation: str = "cubic",
             source: str = "path") -> tuple[NDArray, NDArray]:
    """Interpolate rows ``(time, q)`` at ``time[0] + k dt`` (:func:`from_csv`).

    Parameters
    ----------
    time : (R,) strictly increasing sample times [s], R >= 2.
    q : (R, n) positions at those times [rad | m].
    dt : interpolation cycle [s], already checked.
    interpolation : a name of :data:`INTERPOLATIONS`, already checked. Each joint is
        interpolated on its own (its own end conditions); a joint whose rows are all equal
        stays exactly there.
    source : the rows' file, for messages.

    Returns
    -------
    t : (K,) cycle times [s]; q : (K, n), its first and last rows those of the samples.

    Raises
    ------
    ProgramFileError
        ``"quintic"`` with too few rows: it needs two more than the rows' two ends, plus two
        for each end where the path is not at rest.
    StateError
        Too many cycles (:func:`mrnea.trajectory.cycles`).
    """
    # at least one cycle: a span within CYCLE_TOL of 0 cycles (rows 1e-12 s apart) made a
    # path of one cycle, which the simulator refused without naming the file
    K = max(int(cycles(time[-1] - time[0], dt)), 1) + 1
    require_path_memory(K, q.shape[1])
    t = time[0] + np.arange(K, dtype=float) * dt
    at = np.minimum(t, time[-1])  # past the last row: hold it
    out = np.empty((K, q.shape[1]))
    for i in range(q.shape[1]):
        y = q[:, i]
        if (y == y[0]).all():
            out[:, i] = y[0]
        elif interpolation == "linear":
            out[:, i] = np.interp(at, time, y)
        else:
            out[:, i] = _spline(time, y, 3 if interpolation == "cubic" else 5, source)(at)
    out[0] = q[0]
    out[-1] = q[-1]
    return t, out


def _spline(time: NDArray, y: NDArray, k: int, source: str = "path"):
    """The interpolating spline of odd degree k (3 or 5) of one joint's rows, with the end
    conditions of the module docstring: at an end at rest (two equal rows) the derivatives of
    orders 1..(k - 1)/2 are zero, at any other end "not-a-knot" (the (k - 1)/2 rows nearest to
    it are no knots)."""
    from scipy.interpolate import CubicSpline, make_interp_spline

    rest = (y[1] == y[0], y[-1] == y[-2])
    if k == 3:  # CubicSpline also takes two or three rows (a line, a parabola)
        return CubicSpline(time, y, bc_type=tuple((1, 0.0) if r else "not-a-knot"
                                                  for r in rest))
    m = (k - 1) // 2
    inner = time[1:-1]
    inner = inner[(0 if rest[0] else m):inner.size - (0 if rest[1] else m)]
    needed = 2 + m * (2 - sum(rest))
    if time.size < needed:
        raise ProgramFileError(f"{source}: a quintic spline through {time.size} rows needs at "
                               f"least {needed} (two more for each end not at rest); use "
                               f"interpolation \"cubic\"")
    knots = np.concatenate([np.full(k + 1, time[0]), inner, np.full(k + 1, time[-1])])
    zero = [(d, 0.0) for d in range(1, m + 1)]
    return make_interp_spline(time, y, k=k, t=knots,
                              bc_type=(zero if rest[0] else None, zero if rest[1] else None))


def degree_hint(robot: Robot, rows: NDArray, source: str) -> None:
    """A :class:`mrnea.errors.PathWarning` when rows read in rad start outside a joint's
    position limits and look like degrees: every revolute value within +-360 and some beyond a
    turn (2 pi), which a joint path in rad rarely is. ``rows``: (R, 1 + n) time and positions."""
    q0, revolute = rows[0, 1:], ~robot.is_prismatic
    outside = np.flatnonzero((q0 < robot.lower) | (q0 > robot.upper))
    values = np.abs(rows[:, 1:][:, revolute])
    if outside.size == 0 or values.size == 0 or values.max() > 360.0 or values.max() <= 2 * np.pi:
        return
    i = int(outside[0])
    said = (f"{source}: the joint columns look like degrees (every value within ±360, up to "
            f"{values.max():.4g}); read in rad, joint '{robot.joint_names[i]}' starts at "
            f"{q0[i]:.4g}, outside its limits [{robot.lower[i]:.4g}, {robot.upper[i]:.4g}]: if "
            "the file is in degrees (mm for prismatic joints), pass ")
    warnings.warn(PathWarning(said + 'units="deg"', cli=said + "--units deg"), stacklevel=3)


def limit_warnings(robot: Robot, t: NDArray, q: NDArray, rows: NDArray, interpolation: str,
                   source: str) -> None:
    """A :class:`mrnea.errors.PathWarning` for each joint whose resampled path leaves the
    robot's position limits although every row of the CSV is within them.

    The simulator clamps a command beyond a limit, which the verdict reports as a clamped
    (saturated) joint: here it would be one the rows never asked for. The warning names the
    joint, the first time and the largest excess, and the remedy.

    Parameters
    ----------
    robot : the robot the path is for (n joints).
    t, q : (K,) cycle times [s] and (K, n) the resampled path [rad | m].
    rows : (R, 1 + n) the CSV's rows (time, positions), as resampled.
    interpolation : the interpolation used (for the message).
    source : the file, first in the message.
    """
    lower, upper = robot.lower, robot.upper
    within = ((rows[:, 1:] >= lower) & (rows[:, 1:] <= upper)).all(axis=0)
    for i in np.flatnonzero(within):
        outside = (q[:, i] < lower[i]) | (q[:, i] > upper[i])
        if not outside.any():
            continue
        k = int(np.argmax(outside))
        excess = max(lower[i] - q[:, i].min(), q[:, i].max() - upper[i])
        unit = "m" if robot.joints[i].is_prismatic else "rad"
        warnings.warn(
            f"{source}: joint '{robot.joint_names[i]}': the {interpolation} interpolation "
            f"between the rows leaves the position limits [{lower[i]:.6g}, {upper[i]:.6g}] "
            f"{unit} at t = {t[k]:.6g} s (by up to {excess:.3g} {unit}), although every row is "
            f"within them; the simulator would clamp the command there, a saturation the rows "
            f"do not ask for: give rows closer together or interpolation \"linear\"",
            PathWarning, stacklevel=3)


def save_csv(path: str | os.PathLike[str], t: NDArray, q: NDArray, names: Sequence[str],
             overwrite: bool = False) -> Path:
    """Write a path CSV (the format :func:`from_csv` reads): a header ``t, <names>``, then one
    row per sample, time [s] and positions [rad | m], every number as Python's shortest repr
    (it reads back bit for bit). Through :func:`mrnea.io.writer.create`: whole or not at all,
    never through a link, an existing file replaced only with ``overwrite``.

    Parameters
    ----------
    t : (K,) time [s]. q : (K, n) positions. names : the n joint column names.
    """
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["t", *names])
    writer.writerows([repr(float(a)), *map(repr, row)] for a, row in zip(
        np.asarray(t, dtype=float).tolist(), np.asarray(q, dtype=float).tolist(), strict=True))
    with create(path, overwrite) as fh:
        fh.write(buf.getvalue())
    return Path(path)
