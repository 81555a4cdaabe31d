"""Path CSV files: a recorded or externally planned path (time, q1..qn), resampled to the cycle dt.

The layout is in :func:`from_csv` and ``docs/programs.md``; a program file may name such a file
(:mod:`mrnea.io.program`). The cycle grid is :func:`mrnea.trajectory.cycles`, the same as the
waypoint profiles'.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import ProgramFileError, StateError
from mrnea.io.tomlcheck import read_text
from mrnea.io.writer import create
from mrnea.trajectory import cycles
from mrnea.validate import time_step

__all__ = ["from_csv", "read_table", "resample", "save_csv"]


def read_table(path: Path, n: int | None) -> tuple[list[str], NDArray[np.float64]]:
    """Header and (R, 1 + n) numeric rows of a path CSV, every cell checked.

    Parameters
    ----------
    path : the ``.csv`` file.
    n : expected number of joint columns; None: any (at least one).

    Returns
    -------
    header : the column names.
    rows : (R, 1 + n) time [s] and joint positions, R >= 2, time strictly increasing.

    Raises
    ------
    ProgramFileError
        Naming the file, the line (data row) and the column at fault.
    """
    text = read_text(path, "path CSV file", ProgramFileError)
    header: list[str] | None = None
    header_line = 0
    rows: list[list[float]] = []
    reader = csv.reader(text.splitlines())
    for cells in reader:
        line = reader.line_num
        cells = [c.strip() for c in cells]
        if not any(cells) or cells[0].startswith("#"):
            continue  # blank line or comment
        if header is None:
            header, header_line = cells, line
            if len(header) < 2:
                raise ProgramFileError(
                    f"{path}: line {line}: the header row needs a time column and at least one "
                    f"joint column, got {len(header)} column(s): {header}")
            if n is not None and len(header) != n + 1:
                raise ProgramFileError(
                    f"{path}: line {line}: expected {n + 1} columns (time + {n} joints), the "
                    f"header row has {len(header)}: {header}")
            if _is_number(header[0]):
                raise ProgramFileError(
                    f"{path}: line {line}: the first row must be a header (e.g. t,q1,q2,...), "
                    f"got numbers: {header}")
            continue
        if len(cells) != len(header):
            raise ProgramFileError(
                f"{path}: line {line} (data row {len(rows) + 1}): expected {len(header)} "
                f"columns as in the header (line {header_line}), got {len(cells)}")
        values = []
        for col, cell in enumerate(cells):
            where = (f"{path}: line {line} (data row {len(rows) + 1}), column {col + 1} "
                     f"('{header[col]}')")
            try:
                v = float(cell)
            except ValueError:
                raise ProgramFileError(
                    f"{where}: not a number: {cell!r}" if cell else f"{where}: empty cell"
                ) from None
            if not math.isfinite(v):
                raise ProgramFileError(f"{where}: {cell!r} is not a finite number")
            values.append(v)
        if rows and values[0] <= rows[-1][0]:
            raise ProgramFileError(
                f"{path}: line {line} (data row {len(rows) + 1}), column 1 ('{header[0]}'): "
                f"time {values[0]!r} s is not greater than the previous row's {rows[-1][0]!r} s "
                "(time must be strictly increasing)")
        rows.append(values)
    if header is None:
        raise ProgramFileError(f"{path}: empty file: expected a header row (time, then one column "
                               "per joint) and at least two data rows")
    if len(rows) < 2:
        raise ProgramFileError(f"{path}: {len(rows)} data row(s) after the header: a path needs "
                               "at least two (time strictly increasing)")
    return header, np.array(rows, dtype=np.float64)


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def from_csv(
    path: str | Path, dt: float, n: int | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Read a path CSV (time, q1..qn) and resample it to the interpolation cycle dt.

    File layout: one header row (column names, free text), then one row per sample: time [s]
    (strictly increasing, need not be uniform) and n joint positions [rad | m]. Cells may be
    padded with spaces; blank lines and lines whose first cell starts with ``#`` are ignored.

    Resampling is **linear interpolation** between the rows, at ``t[k] = t_first + k dt`` from
    the first row's time to the last's. It reproduces the rows exactly (and any path linear in
    time), never overshoots (no position outside the rows' range, so no new limit violations)
    and needs no smoothing parameter. But between rows the velocity is constant, so it steps at
    every row: when the rows are coarser than dt, the second difference (the acceleration the
    simulator asks for) spikes at each row. Give the path at dt or finer, or smooth it first.
    If the time span is not a whole number of cycles, the last cycle falls after the last row
    and holds its position: the last commanded row always equals the CSV's last row.

    Parameters
    ----------
    path : the ``.csv`` file.
    dt : interpolation cycle [s], finite and > 0.
    n : expected number of joints (columns after the time column); None: any, from the header.

    Returns
    -------
    t : (K,) cycle times ``t_first + k dt`` [s], K >= 2.
    q : (K, n) commanded positions.

    Raises
    ------
    ProgramFileError
        Missing or empty file, wrong column count, non-numeric / empty / NaN / inf cell, time not
        strictly increasing, fewer than two data rows; the message names the file, the line
        (data row) and the column.
    StateError
        Bad ``dt`` or ``n``.
    """
    dt = time_step(dt)
    if n is not None and (isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1):
        raise StateError(f"n: expected a number of joints >= 1 or None, got {n!r}")
    p = Path(path)
    _, data = read_table(p, None if n is None else int(n))
    return resample(data[:, 0], data[:, 1:], dt)


def resample(time: NDArray, q: NDArray, dt: float) -> tuple[NDArray, NDArray]:
    """Linear interpolation of rows ``(time, q)`` at ``time[0] + k dt`` (:func:`from_csv`).

    Parameters
    ----------
    time : (R,) strictly increasing sample times [s].
    q : (R, n) positions at those times.
    dt : interpolation cycle [s], already checked.

    Returns
    -------
    t : (K,) cycle times [s]; q : (K, n), its first and last rows those of the samples.
    """
    K = int(cycles(time[-1] - time[0], dt)) + 1
    t = time[0] + np.arange(K, dtype=float) * dt
    out = np.empty((K, q.shape[1]))
    for i in range(q.shape[1]):
        out[:, i] = np.interp(t, time, q[:, i])
    out[0] = q[0]
    out[-1] = q[-1]
    return t, out


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
