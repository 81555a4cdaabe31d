"""A measurement log: time, joint positions and joint-side efforts (:class:`Log`), its velocities
and accelerations by a zero-phase filter (:func:`derivatives`), and its CSV form
(:func:`read_log`).

Filter: the positions are low-passed by a 4th-order Butterworth filter run forwards and
backwards (``scipy.signal.sosfiltfilt``: no phase lag, effective order 8, -6 dB at the cut-off
``cutoff_hz``, default :data:`CUTOFF_HZ`), then differentiated twice by second-order central
differences on the time stamps (``numpy.gradient``). An excitation trajectory of harmonics up to
a few Hz passes unchanged (at 0.5 Hz and a 10 Hz cut-off the gain differs from 1 by 4e-11);
encoder quantisation and noise above the cut-off are removed before they are differentiated.
The efforts are not filtered: their noise stays white, so the standard errors of the least
squares (:mod:`mrnea.identify.estimate`) hold.
"""

from __future__ import annotations

import csv
import os
import warnings
from array import array
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from itertools import chain
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import validate
from mrnea.errors import LogFileError, StateError, listing, quote
from mrnea.io.source import (
    MAX_CSV_SIZE,
    after_line,
    float_reads_grammar,
    line_blocks,
    parse_number,
    read_text,
)
from mrnea.model import Robot
from mrnea.resources import format_bytes, require_memory

CUTOFF_HZ = 10.0  # the position filter's default cut-off [Hz]
#: The largest magnitude of a log's number (time [s], q [rad | m], efforts [N m | N], qd, qdd):
#: beyond, the least squares' sums of squares overflow.
LOG_BOUND = 1e12
#: The lowest cut-off the filter takes, as a fraction of the sample rate: below, the
#: Butterworth design loses its digits (at 1e-8 its gain is off by 7 %, at 1e-10 it is singular).
MIN_CUTOFF_RATIO = 1e-6
FILTER_ORDER = 4
#: The fewest samples a log holds (26): the zero-phase filter pads each end with samples
#: reflected from the log, and needs a log well longer than that padding.
MIN_SAMPLES = 2 * (3 * FILTER_ORDER + 1)
#: The column delimiters of a log CSV, by name; the header row says which (the first of these
#: it holds).
DELIMITERS = {",": "comma", ";": "semicolon", "\t": "tab"}


@dataclass(frozen=True)
class Log:
    """A log of K samples of an n-joint robot: ``time`` (K,) [s], strictly increasing; ``q``
    (K, n) [rad | m]; ``tau`` (K, n) joint-side efforts [N m | N]; optionally ``qd``, ``qdd``
    (K, n) (else :func:`derivatives`)."""

    time: NDArray[np.float64]
    q: NDArray[np.float64]
    tau: NDArray[np.float64]
    qd: NDArray[np.float64] | None = None
    qdd: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        t = validate.numeric(self.time, "log: time")
        if t.ndim != 1:
            raise StateError(f"log: time must be (K,), got shape {t.shape}")
        if t.size < MIN_SAMPLES:
            raise StateError(f"log: {t.size} samples; a log needs at least {MIN_SAMPLES} (the "
                             "position filter's edges)")
        K = t.size
        for name in ("q", "tau", "qd", "qdd"):
            v = getattr(self, name)
            if v is None and name in ("qd", "qdd"):
                continue
            a = validate.numeric(v, f"log: {name}")
            if a.ndim != 2 or a.shape[0] != K:
                raise StateError(f"log: {name} must be ({K}, n), got shape {a.shape}")
            bad = np.argwhere(~np.isfinite(a))
            if bad.size:
                raise StateError(f"log: {name} is NaN or inf at sample {bad[0][0]}")
            big = np.argwhere(np.abs(a) > LOG_BOUND)
            if big.size:
                k, j = big[0]
                raise StateError(f"log: {name} of joint {j + 1} is {a[k, j]:.3g} at sample {k}, "
                                 f"beyond {LOG_BOUND:g}, the largest mrnea accepts in a log "
                                 "(check its units)")
            object.__setattr__(self, name, a)
        bad = np.flatnonzero(~(np.diff(t) > 0))
        if bad.size or not np.isfinite(t).all():
            k = int(bad[0]) + 1 if bad.size else int(np.flatnonzero(~np.isfinite(t))[0])
            raise StateError(f"log: time must increase strictly and be finite (sample {k})")
        if np.abs(t).max() > LOG_BOUND:
            raise StateError(f"log: time {t[np.argmax(np.abs(t))]:.3g} s is beyond {LOG_BOUND:g} "
                             "s, the largest mrnea accepts in a log (check its units)")
        object.__setattr__(self, "time", t)

    @property
    def K(self) -> int:
        return self.time.size

    def part(self, sl: slice) -> Log:
        """The samples ``sl`` (velocities and accelerations kept if given)."""
        cut = (lambda a: None if a is None else a[sl])  # noqa: E731
        return Log(self.time[sl], self.q[sl], self.tau[sl], cut(self.qd), cut(self.qdd))


def sample_rate(time: NDArray, cutoff_hz: object) -> tuple[float, float]:
    """The log's sample rate [Hz] (the median time step's inverse) and ``cutoff_hz`` [Hz],
    checked: from MIN_CUTOFF_RATIO of the rate to below half of it (Nyquist)."""
    cutoff_hz = validate.real(cutoff_hz, "cutoff_hz")
    with np.errstate(divide="ignore", over="ignore"):
        fs = 1.0 / float(np.median(np.diff(time)))
    if not MIN_CUTOFF_RATIO * fs <= cutoff_hz < fs / 2:
        raise StateError(f"cutoff_hz: the filter's cut-off {cutoff_hz} Hz must be in "
                         f"[{MIN_CUTOFF_RATIO * fs:g}, {fs / 2:g}) Hz, from {MIN_CUTOFF_RATIO:g} "
                         f"to half the log's sample rate {fs:g} Hz")
    return fs, cutoff_hz


def derivatives(time: ArrayLike, q: ArrayLike, cutoff_hz: float = CUTOFF_HZ
                ) -> tuple[NDArray, NDArray, NDArray]:
    """Filtered q, qd, qdd (K, n) of positions q (K, n) sampled at ``time`` (K,) [s]
    (module docstring). The sample rate is the median of the time steps; ``cutoff_hz`` must be
    below half of it (Nyquist)."""
    t, q = validate.numeric(time, "time"), validate.numeric(q, "q")
    fs, cutoff_hz = sample_rate(t, cutoff_hz)
    import scipy.signal  # here: scipy.signal (and scipy.stats) would add ~0.5 s to every command

    sos = scipy.signal.butter(FILTER_ORDER, cutoff_hz, fs=fs, output="sos")
    qf = scipy.signal.sosfiltfilt(sos, q, axis=0)
    qd = np.gradient(qf, t, axis=0)
    return qf, qd, np.gradient(qd, t, axis=0)


def log_columns(robot: Robot, currents: bool = False) -> list[str]:
    """The CSV header of a log: ``time [s]``, ``<joint> [rad|m]`` per joint, then
    ``tau_<joint> [N m|N]`` (``currents``: ``i_<joint> [A]``)."""
    units = [j.unit("q") for j in robot.joints]
    effort = ([f"i_{j.name} [A]" for j in robot.joints] if currents else
              [f"tau_{j.name} [{j.unit('tau')}]" for j in robot.joints])
    return (["time [s]"] + [f"{j.name} [{u}]" for j, u in zip(robot.joints, units, strict=True)]
            + effort)


def read_log(path: str | Path, robot: Robot, torque_constant: ArrayLike | None = None) -> Log:
    """A log from a CSV file with a header row (:func:`log_columns`; the unit in brackets is
    optional and, given, must be mrnea's (s, rad or m, N m or N, A; spaces, ``*`` and ``^``
    aside), columns in any order, others ignored). Optional ``qd_<joint>`` and ``qdd_<joint>``
    columns (all joints) give velocities and accelerations.

    The columns are separated by the header row's delimiter (:data:`DELIMITERS`: a comma, else a
    semicolon, else a tab), every row has the header's count of cells, blank lines are skipped,
    and every number used is in :func:`mrnea.io.source.parse_number`'s grammar. The file is at
    most :data:`mrnea.io.source.MAX_CSV_SIZE` bytes, its reading within the memory budget
    (:mod:`mrnea.resources`), with at least :data:`MIN_SAMPLES` data rows.

    ``torque_constant``: one number or one per joint [N m/A, motor side]: the log has motor
    currents ``i_<joint>`` instead of efforts, and ``tau = G k_t i`` (joint side, G the gear
    ratio).

    Raises LogFileError naming the file and the row (the file's line, 1-based: the header is
    row 1 unless blank lines precede it) or column.
    """
    try:
        size = os.stat(path).st_size
    except (OSError, ValueError, TypeError):
        size = 0  # read_text says what is wrong with the path
    if size <= MAX_CSV_SIZE:  # the text (bytes and str) and the numbers: 8 bytes per >= 2 bytes
        require_memory(9 * size, f"{path}: reading this {format_bytes(size)} log",
                       "log at a lower rate or split the log", LogFileError)
    text = read_text(path, "log", LogFileError, MAX_CSV_SIZE)
    lines = _lines(text)
    first = next(((k, line) for k, line in lines if line.strip(" \t")), None)
    if first is None:
        raise LogFileError(f"{path}: empty log: expected a header row (time, the joint "
                           "positions and efforts) and the data rows")
    head_row, head_text = first
    delimiter = next((d for d in DELIMITERS if d in head_text), ",")
    try:
        header_cells = next(csv.reader([head_text], delimiter=delimiter), [])
    except csv.Error as exc:
        raise LogFileError(f"{path}: row {head_row}: not valid CSV: {exc}") from None
    header = [h.split("[")[0].strip() for h in header_cells]
    names = robot.joint_names
    effort = "i_" if torque_constant is not None else "tau_"
    need = ["time", *names, *(effort + j for j in names)]
    missing = [c for c in need if c not in header]
    if missing:
        shape = ("; the header row is one column: separate its cells by a comma, a semicolon "
                 "or a tab" if len(header) == 1 else "")
        raise LogFileError(f"{path}: row {head_row}: missing column {quote(missing[0])} "
                           f"(needed: time, the joint positions and {effort}<joint> for joints "
                           f"{listing(names)}){shape}")
    optional = [p + j for p in ("qd_", "qdd_") for j in names]
    has_rates = all(c in header for c in optional)
    used = need + (optional if has_rates else [])
    twice = next((c for c in used if header.count(c) > 1), None)
    if twice is not None:
        one = header.index(twice)
        raise LogFileError(f"{path}: row {head_row}: column {quote(twice)} appears twice "
                           f"(columns {one + 1} and {header.index(twice, one + 1) + 1})")
    cols = [header.index(c) for c in used]
    _check_units(path, head_row, header_cells, cols, _units(robot, effort, has_rates))
    head_end = after_line(text, head_row)
    # past the header's line end: else float reads the grammar's numbers
    strict = head_end is not None and not float_reads_grammar(text, head_end)
    data, rows = _numbers(path, lines, delimiter, len(header_cells), used, cols, strict)
    if data.shape[0] < MIN_SAMPLES:
        raise LogFileError(f"{path}: {data.shape[0]} data row(s) after the header; a log needs "
                           f"at least {MIN_SAMPLES} samples (the position filter's edges)")
    back = np.flatnonzero(~(np.diff(data[:, 0]) > 0))
    if back.size:
        r = int(back[0]) + 1
        raise LogFileError(f"{path}: row {rows[r]}: time {data[r, 0]:g} s does not increase "
                           f"(row {rows[r - 1]}: {data[r - 1, 0]:g} s)")
    big = np.argwhere(np.abs(data) > LOG_BOUND)
    if big.size:
        r, c = big[0]
        raise LogFileError(f"{path}: row {rows[r]}: column {quote(used[c])} is {data[r, c]:.3g}, "
                           f"beyond {LOG_BOUND:g}, the largest mrnea accepts in a log (check its "
                           "units)")
    if not has_rates:  # a log read, not refused
        _steady(path, data[:, 0], rows)
    n = robot.n
    tau = data[:, 1 + n:1 + 2 * n]
    if torque_constant is not None:
        kt = np.asarray(torque_constant, dtype=float).ravel()
        if kt.size not in (1, n) or not np.all((kt > 0) & np.isfinite(kt)):
            raise StateError(f"torque constant: expected one number > 0 or {n} (one per joint: "
                             f"{listing(robot.joint_names)}), got {kt.size}: "
                             f"{quote(kt.tolist())}")
        kt = np.broadcast_to(kt, (n,))
        tau = tau * kt * robot.gear_ratio
    rates = (data[:, 1 + 2 * n:1 + 3 * n], data[:, 1 + 3 * n:]) if has_rates else (None, None)
    try:
        return Log(data[:, 0], data[:, 1:1 + n], tau, *rates)
    except StateError as exc:
        raise LogFileError(f"{path}: {exc}") from None


def _steady(path: str | Path, time: NDArray, rows: Sequence[int]) -> None:
    """Warn where the time step of a log without rate columns leaves [1/2, 3/2] of its median:
    the zero-phase filter that gives the rates takes the samples as equally spaced, so the
    rates near such a step (a gap, dropped samples, heavy jitter) are not the motion's."""
    dt = np.diff(time)
    med = float(np.median(dt))
    odd = np.flatnonzero((dt > 1.5 * med) | (dt < 0.5 * med))
    if odd.size:
        r = int(odd[0]) + 1
        warnings.warn(f"{path}: the time step varies from {dt.min():.3g} s to {dt.max():.3g} s "
                      f"(median {med:.3g} s; {odd.size} step(s) beyond half or 1.5 times it, the "
                      f"first before row {rows[r]}): the rates' filter takes the samples as "
                      "equally spaced, so the fit near those steps is approximate; resample the "
                      "log to a steady rate, or give qd_<joint> and qdd_<joint> columns",
                      stacklevel=3)


def _lines(text: str) -> Iterator[tuple[int, str]]:
    """(line number, line without its end) of every line of ``text``, read in blocks without a
    list of every line (a log may be a GiB). Only LF, CRLF and a lone CR end a line
    (:func:`~mrnea.io.source.line_blocks`): a lone-CR log was one row, not valid CSV."""
    return enumerate(chain.from_iterable(line_blocks(text)), start=1)


def _numbers(path: str | Path, lines: Iterator[tuple[int, str]], delimiter: str,
             width: int, used: list[str], cols: list[int], strict: bool
             ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """(R, len(cols)) numbers of the data rows ``lines`` holds after the header, and each row's
    line number. Every row has ``width`` cells; every cell used is a number in
    :func:`parse_number`'s grammar (``strict``: read by it; else by ``float``, which reads the
    same where the rows hold no ``_`` and nothing but ASCII), finite."""
    numbers, where = array("d"), array("q")
    row = [0]

    def data_lines() -> Iterator[str]:
        for number, line in lines:
            if line.strip(" \t"):  # a blank line is skipped
                row[0] = number
                yield line

    read = parse_number if strict else float
    try:
        for cells in csv.reader(data_lines(), delimiter=delimiter):
            if len(cells) != width:
                held = [name for d, name in DELIMITERS.items()
                        if d != delimiter and any(d in c for c in cells)]
                raise LogFileError(
                    f"{path}: row {row[0]}: {len(cells)} columns, the header has {width}"
                    + (f" (the row holds a {held[0]}; the header's delimiter, a "
                       f"{DELIMITERS[delimiter]}, separates every row's cells)" if held else ""))
            try:
                numbers.extend([read(cells[c].strip(" \t")) for c in cols])
            except ValueError:
                for name, c in zip(used, cols, strict=True):
                    cell = cells[c].strip(" \t")
                    try:
                        parse_number(cell)
                    except ValueError as exc:
                        hint = (" (numbers use a decimal point, not a comma)"
                                if "," in cell and delimiter != "," else "")
                        raise LogFileError(f"{path}: row {row[0]}: column {quote(name)}: "
                                           + (str(exc) + hint if cell else "empty cell")
                                           ) from None
                raise  # float refused what the grammar reads: not reached
            where.append(row[0])
    except csv.Error as exc:
        raise LogFileError(f"{path}: row {row[0]}: not valid CSV: {exc}") from None
    data = np.frombuffer(numbers, dtype=np.float64).reshape(-1, len(cols)).copy()
    rows = np.frombuffer(where, dtype=np.int64).copy()
    bad = np.argwhere(~np.isfinite(data))
    if bad.size:
        r, c = bad[0]
        raise LogFileError(f"{path}: row {rows[r]}: column {quote(used[c])} is NaN or inf")
    return data, rows


def _units(robot: Robot, effort: str, rates: bool) -> list[str]:
    """The unit of each column :func:`read_log` uses, in its order."""
    joints = robot.joints
    out = ["s", *(j.unit("q") for j in joints),
           *(("A",) * robot.n if effort == "i_" else (j.unit("tau") for j in joints))]
    return out + ([*(j.unit("qd") for j in joints), *(j.unit("qdd") for j in joints)]
                  if rates else [])


def _spelled(unit: str) -> str:
    """A unit as compared (case matters: nm is no N m): no spaces, ``*``, ``·`` or ``^``, ``²``
    as 2, ``sec`` as s."""
    return "".join(c for c in unit.replace("²", "2") if c not in " *·^").replace("sec", "s")


def _check_units(path: str | Path, row: int, header: list[str], cols: list[int],
                 units: list[str]) -> None:
    """A column whose header gives a unit (``name [unit]``) other than the one mrnea reads it
    in is an error naming it: a log in degrees or milliseconds is never read as radians or
    seconds."""
    for c, unit in zip(cols, units, strict=True):
        name, _, given = header[c].partition("[")
        given = given.split("]")[0].strip()
        if given and _spelled(given) != _spelled(unit):
            raise LogFileError(f"{path}: row {row}: column {quote(name.strip())} is in "
                               f"{quote(given)}; a log gives it in {quote(unit)} (convert it, or "
                               f"leave the unit out)")
