"""The per-cycle table of a simulation: its columns, their CSV rows, and the bearing loads.

What :class:`mrnea.simulate.SimulationResult` shows cycle by cycle, computed from its arrays:
:func:`columns` (the table behind :meth:`~mrnea.simulate.SimulationResult.columns` and
``cycles.csv``, one column per quantity and joint, :data:`PER_JOINT`), :func:`csv_rows` (a
chunk of it as CSV), :func:`program_qdd` (the program's own acceleration) and
:func:`bearing_loads` (the reaction loads along and across each joint's axis). The result's
methods of the same names are the public API; their docstrings say what each column holds.
"""

from __future__ import annotations

import csv
import io
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import StateError
from mrnea.kernels import bearing

if TYPE_CHECKING:
    from mrnea.simulate import SimulationResult

# The per-joint columns of the per-cycle table, in order: the result's array (program_qdd: the
# function below), the column's name, and the quantity of mrnea.model.JOINT_UNITS giving its unit
# (None: a boolean). First the program and its own requirement, then the simulated response, last
# what each cycle asked for from the robot's own state (the catch-up once the robot lags).
# tau_motor = tau / G with G dimensionless: the effort's unit.
PER_JOINT = (
    ("q_cmd", "q_cmd", "q"), ("qd_cmd", "qd_cmd", "qd"), ("program_qdd", "program_qdd", "qdd"),
    ("program_effort", "program_effort", "tau"), ("program_limit", "program_limit", "tau"),
    ("q", "q", "q"), ("qd", "qd", "qd"), ("qdd", "qdd", "qdd"), ("tau", "tau", "tau"),
    ("tau_motor", "tau_motor", "tau"), ("limit", "limit", "tau"), ("margin", "margin", "tau"),
    ("saturated", "saturated", None), ("position_clamped", "position_clamped", None),
    ("velocity_clamped", "velocity_clamped", None), ("tracking_error", "tracking_error", "q"),
    ("coulomb", "coulomb", "tau"), ("stuck", "stuck", None),
    ("qdd_des", "catch_up_qdd", "qdd"), ("tau_required", "catch_up_effort", "tau"))


class BearingLoads(NamedTuple):
    """Each joint's reaction loads split for bearing design, per cycle: (K, n) arrays.

    ``force`` and ``moment`` are the magnitudes of the reaction force [N] and moment [N m];
    ``axial_*`` the magnitude of their component along the joint axis, ``radial_force`` and
    ``bending_moment`` the magnitude of their component across it (joint frames, as
    :attr:`mrnea.simulate.SimulationResult.reaction`).
    """

    force: NDArray
    axial_force: NDArray
    radial_force: NDArray
    moment: NDArray
    axial_moment: NDArray
    bending_moment: NDArray


def bearing_loads(res: SimulationResult) -> BearingLoads:
    """The reaction loads of every cycle of ``res`` split along and across each joint's axis
    (:meth:`mrnea.simulate.SimulationResult.bearing_loads`; kernels/bearing.py); StateError
    without reactions."""
    if res.reaction is None:
        raise StateError("bearing_loads: this run did not compute the joint reactions "
                         "(simulate(..., reactions=False)); simulate again with reactions")
    axes = np.array([j.axis for j in res.robot.joints])  # unit axes, joint frames
    out = np.empty((6, res.K, res.robot.n))
    bearing.bearing_loads(res.reaction, axes, out)
    return BearingLoads(*out)


def program_qdd(res: SimulationResult, rows: slice) -> NDArray:
    """The program's own acceleration [rad/s^2 | m/s^2] at the cycles ``rows`` of ``res``
    (:meth:`mrnea.simulate.SimulationResult.program_qdd`)."""
    start, stop, _ = rows.indices(res.K)
    v = res.qd_cmd[start:stop]
    following = np.zeros_like(v)
    nxt = res.qd_cmd[start + 1:stop + 1]
    following[:nxt.shape[0]] = nxt
    return (following - v) / res.dt


def columns(res: SimulationResult, rows: slice) -> dict[str, NDArray]:
    """The per-cycle table of ``res`` at the cycles ``rows`` as named 1-D columns
    (:meth:`mrnea.simulate.SimulationResult.columns`, which lists them)."""
    if not isinstance(rows, slice):
        raise StateError(f"rows: expected a slice of cycles, got {type(rows).__name__}")
    cols: dict[str, NDArray] = {"t [s]": res.t[rows]}
    for attr, name, quantity in PER_JOINT:
        a = program_qdd(res, rows) if attr == "program_qdd" else getattr(res, attr)[rows]
        for i, j in enumerate(res.robot.joints):
            unit = "" if quantity is None else f" [{j.unit(quantity)}]"
            cols[f"{name}_{j.name}{unit}"] = a[:, i]
    for i, j in enumerate(res.robot.joint_names if res.reaction is not None else ()):
        for c, label in enumerate(("fx", "fy", "fz", "nx", "ny", "nz")):
            unit = "N" if c < 3 else "N m"
            cols[f"reaction_{label}_{j} [{unit}]"] = res.reaction[rows, i, c]
    if res.tool_position_error is not None:
        cols["tool_position_error [m]"] = res.tool_position_error[rows]
        cols["tool_orientation_error [rad]"] = res.tool_orientation_error[rows]
    return cols


def csv_rows(res: SimulationResult, rows: slice, header: bool = False) -> bytes:
    """The table's ``rows`` as UTF-8 CSV, after the header row if ``header``."""
    buf = io.StringIO()
    writer = csv.writer(buf)
    cols = columns(res, rows)
    if header:
        writer.writerow(cols)
    writer.writerows(zip(*(c.tolist() for c in cols.values()), strict=True))
    return buf.getvalue().encode()
