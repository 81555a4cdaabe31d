"""One row of a design sweep: a program simulated on a robot variant, as a flat summary.

Usage: ``row = run_case(robot, program, {"payload": 5.0})``; on a Dask worker,
``run_batch(jobs, robot, programs)`` runs many and returns ``(job index, row)`` pairs.

A row holds :data:`TOP_COLUMNS`, the first infeasible instant (:data:`FIRST_COLUMNS`), and
every number the summary gives per joint, as ``<entry>.<joint>`` (peak and RMS motor torque,
effort ratio, peak speed, peak reaction force and moment...): the columns are taken from
:meth:`mrnea.simulate.SimulationResult.summary` by name, so they follow it. ``error`` is None,
or why this variant failed (``"<ErrorType>: <message>"``, the other columns then empty): a
failed variant is a row, never a lost sweep. With ``retime``, :data:`RETIME_COLUMNS` from
:func:`mrnea.retime` of the variant and its program.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import hashlib
import math
import os
import time
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numba
import numpy as np

from mrnea.errors import ModelWarning, MrneaError
from mrnea.io.program import Program
from mrnea.model import Robot
from mrnea.retime.core import retime as retime_program
from mrnea.simulate import simulate
from mrnea.sweep.variants import variant

__all__ = ["FIRST_COLUMNS", "QUANTITY", "RETIME_COLUMNS", "TOP_COLUMNS", "code_version",
           "column_units", "run_batch", "run_case", "summary_row", "tune_worker", "warm"]

#: Top-level summary entries copied into each row (those the summary has).
TOP_COLUMNS = ("achievable", "worst_joint", "worst_effort_ratio", "duration",
               "max_tracking_error", "runaway_time")
#: The first infeasible instant's columns (NaN and None when there is none).
FIRST_COLUMNS = ("first_infeasible_time", "first_infeasible_joint", "first_infeasible_reason")
#: The columns of ``retime=True``: the retimed duration [s] and why retiming failed (or None).
RETIME_COLUMNS = ("retimed_duration", "retime_error")
#: The quantity of each number column (a summary entry, per joint as ``<entry>.<joint>``), for
#: its unit (:func:`column_units`); None: a pure number or a flag. A summary entry not listed
#: here has no unit in the files (tests/test_sweep_reliability.py checks every entry is).
QUANTITY = {
    "duration": "time", "max_tracking_error": "position", "worst_effort_ratio": None,
    "runaway_time": "time",
    "first_infeasible_time": "time", "retimed_duration": "time",
    "effort_limit": "effort", "program_peak_effort": "effort", "program_peak_time": "time",
    "program_rms_effort": "effort", "program_peak_motor_torque": "motor",
    "program_rms_motor_torque": "motor", "program_effort_ratio": None,
    "program_ratio_time": "time", "program_effort_at_ratio": "effort",
    "program_speed_at_ratio": "speed",
    "program_limit_at_ratio": "effort", "program_beyond_no_load_speed": None,
    "program_first_over_time": "time", "time_saturated": "time", "time_stuck": "time",
    "peak_motor_torque": "motor", "rms_motor_torque": "motor", "peak_effort": "effort",
    "peak_speed": "speed", "peak_reaction_force": "force", "peak_axial_force": "force",
    "peak_radial_force": "force", "peak_reaction_moment": "moment",
    "peak_bending_moment": "moment", "max_tracking_error_time": "time",
    "final_position_error": "position"}
#: SI unit of each quantity: (revolute joint, prismatic joint).
_UNIT = {"time": ("s", "s"), "position": ("rad", "m"), "speed": ("rad/s", "m/s"),
         "effort": ("N m", "N"), "motor": ("N m", "N m"), "force": ("N", "N"),
         "moment": ("N m", "N m")}


def column_units(robot: Robot, columns: Sequence[str]) -> dict[str, str]:
    """The unit of each result column of a sweep of ``robot`` that has one: a top-level
    column's (``"rad | m"`` for ``max_tracking_error`` on a robot with both kinds of joint),
    a per-joint column's by its joint's kind. Parameters, text, flags and ratios: none."""
    kinds = {j.name: j.is_prismatic for j in robot.joints}
    out = {}
    for col in columns:
        entry, _, joint = col.partition(".")
        quantity = QUANTITY.get(entry)
        if quantity is None:
            continue
        if joint in kinds:
            out[col] = _UNIT[quantity][kinds[joint]]
        elif not joint:
            out[col] = " | ".join(dict.fromkeys(_UNIT[quantity][p]
                                                for p in sorted(set(kinds.values()))))
    return out


def summary_row(summary: Mapping[str, Any]) -> dict[str, Any]:
    """A summary as one flat row: :data:`TOP_COLUMNS`, :data:`FIRST_COLUMNS`, and each
    per-joint entry that is a number, a boolean or None as ``<entry>.<joint>``."""
    row = {key: summary[key] for key in TOP_COLUMNS if key in summary}
    first = summary.get("first_infeasible")
    row.update(zip(FIRST_COLUMNS, (first["time"], first["joint"], first["reason"]) if first
                   else (math.nan, None, None), strict=True))
    for j in summary["joints"]:
        for key, value in j.items():
            if value is None or isinstance(value, (int, float)):
                row[f"{key}.{j['joint']}"] = value
    return row


# --- runs ----------------------------------------------------------------------------------


def _error(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def run_case(robot: Robot, program: Program, params: Mapping[str, Any], retime: bool = False
             ) -> dict[str, Any]:
    """One sweep row: ``program`` (time-scaled already) on ``variant(robot, **params)``.

    Any exception of the variant, its simulation or its summary becomes the row's ``error``
    (a failed variant is a row). With ``retime``, :data:`RETIME_COLUMNS` too.
    """
    row: dict[str, Any] = {"error": None}
    try:
        rob = variant(robot, **params)
        res = simulate(rob, program.q_cmd, program.dt, mode=program.mode or "hybrid",
                       f_ext=program.f_ext, f_ext_point=program.f_ext_point)
        row.update(summary_row(res.summary()))
    except Exception as exc:
        row["error"] = _error(exc)
        return row
    if retime:
        row.update(retime_columns(rob, program))
    return row


def retime_columns(robot: Robot, program: Program) -> dict[str, Any]:
    """:data:`RETIME_COLUMNS` of ``mrnea.retime(robot, program)``: its duration [s], or NaN and
    why it failed."""
    try:
        return {"retimed_duration": float(retime_program(robot, program).duration),
                "retime_error": None}
    except Exception as exc:
        return {"retimed_duration": math.nan, "retime_error": _error(exc)}


def run_batch(jobs: Sequence[tuple[int, tuple[int, float], Mapping[str, Any]]], robot: Robot,
              programs: Mapping[tuple[int, float], Program], retime: bool = False,
              client_pid: int = 0) -> list[tuple[int, dict[str, Any]]]:
    """A Dask task: ``(job index, row)`` for each ``(index, program key, params)`` job, the
    program key being (program number, time scale); in a worker process (not the client's,
    ``client_pid``), :func:`tune_worker` first (a worker that joined after the warm-up)."""
    tune_worker(client_pid, retime)
    return [(k, run_case(robot, programs[key], params, retime)) for k, key, params in jobs]


#: glibc's ``mallopt`` parameters M_TRIM_THRESHOLD and M_MMAP_THRESHOLD.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_TUNED: set[int] = set()  # the process ids tune_worker has tuned (a fork copies the set)


def tune_worker(client_pid: int, retime: bool) -> None:
    """Give a worker of any cluster (a user's ``LocalCluster``, ``dask worker`` processes)
    what mrnea's own LocalCluster gives its workers, so that both run a sweep alike.

    * In a worker process (not the client's), once: glibc's heap kept for the runs' arrays
      (``mallopt``, the values of :data:`mrnea.sweep.cluster.WORKER_MALLOC`: distributed's
      default trim threshold of 64 kB makes glibc map and fault in each run's MB-sized arrays
      afresh, +35 % CPU per run). Elsewhere than glibc: nothing.
    * Numba's parallel kernels on one thread in this task's thread (a thread-local setting):
      the sweep is parallel over tasks already. Only with ``retime`` (a run without it calls
      no parallel kernel): ``numba.set_num_threads`` starts Numba's thread pool, of
      ``NUMBA_NUM_THREADS`` threads (the machine's logical CPUs unless set), in every worker;
      mrnea's LocalCluster starts its workers with ``NUMBA_NUM_THREADS=1``, and so should a
      cluster of one's own that retimes (docs/sweeps.md).
    """
    if retime:
        numba.set_num_threads(1)
    pid = os.getpid()
    if pid == client_pid or pid in _TUNED:
        return
    _TUNED.add(pid)
    from mrnea.sweep.cluster import WORKER_MALLOC

    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None)
        libc.mallopt(_M_TRIM_THRESHOLD, int(WORKER_MALLOC["MALLOC_TRIM_THRESHOLD_"]))
        libc.mallopt(_M_MMAP_THRESHOLD, int(WORKER_MALLOC["MALLOC_MMAP_THRESHOLD_"]))


@functools.cache
def code_version() -> str:
    """What makes two processes' rows equal bit for bit: Numba's version and a digest of
    mrnea's source files (this process's; a worker that runs other code would give other
    rows)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    digest = hashlib.sha256()
    for folder, dirs, files in sorted(os.walk(root)):
        dirs.sort()
        for name in sorted(f for f in files if f.endswith(".py")):
            path = os.path.join(folder, name)
            digest.update(os.path.relpath(path, root).encode())
            with open(path, "rb") as fh:
                digest.update(fh.read())
    return f"numba {numba.__version__}, mrnea source {digest.hexdigest()[:12]}"


def warm(robot: Robot, client_pid: int, retime: bool = False) -> dict[str, Any]:
    """Run on each worker before a sweep: load mrnea's compiled kernels (a 3-cycle run of
    ``robot`` and its summary; with ``retime``, a retiming of a short move too, which also
    imports toppra), tune the worker (:func:`tune_worker`) and, in a worker process of its
    own, silence ModelWarning (each variant would repeat its base robot's). Returns what the
    client checks and says: the :func:`code_version`, the process id and the seconds
    taken."""
    t0 = time.perf_counter()
    if os.getpid() != client_pid:
        warnings.simplefilter("ignore", ModelWarning)
    tune_worker(client_pid, retime)
    q0 = np.clip(np.zeros(robot.n), robot.lower, robot.upper)
    with contextlib.suppress(MrneaError):
        simulate(robot, np.repeat(q0[None], 3, axis=0), 0.005).summary()
    if retime:  # a move of 0.01 rad | m (or to the limit) on every joint
        q1 = np.clip(q0 + 0.01, robot.lower, robot.upper)
        with contextlib.suppress(MrneaError):
            retime_program(robot, np.linspace(q0, q1, 20), dt=0.01)
    return {"code": code_version(), "pid": os.getpid(), "seconds": time.perf_counter() - t0}
