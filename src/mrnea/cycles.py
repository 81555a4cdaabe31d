"""The per-cycle table of a simulation: its columns, their CSV rows, and the bearing loads.

What :class:`mrnea.simulate.SimulationResult` shows cycle by cycle, computed from its arrays:
:func:`columns` (the table behind :meth:`~mrnea.simulate.SimulationResult.columns` and
``cycles.csv``, one column per quantity and joint, :data:`PER_JOINT`), :func:`csv_rows` (a
chunk of it as CSV), :func:`program_qdd` (the program's own acceleration, with
:func:`mrnea.summary.program_next`, what the program commands after the last cycle held),
:func:`bearing_loads` (the reaction loads along and across each joint's axis), and what a run
fills chunk by chunk besides the kernel's arrays (:func:`derive`, :func:`tool_errors`). The result's
methods of the same names are the public API; their docstrings say what each column holds.
"""

from __future__ import annotations

import csv
import io
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray

from mrnea import compiled
from mrnea.errors import StateError
from mrnea.kernels import bearing
from mrnea.kernels.derived import derived
from mrnea.summary import program_next

if TYPE_CHECKING:
    from mrnea.cartesian import CartesianPath
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


def _cycles(res: SimulationResult, rows: object) -> NDArray:
    """The indices of the cycles ``rows`` (a slice, any step) of ``res``; StateError for anything
    else, a slice of non-integers included."""
    if not isinstance(rows, slice):
        raise StateError(f"rows: expected a slice of cycles, got {type(rows).__name__}")
    try:
        return np.arange(*rows.indices(res.K))
    except (TypeError, ValueError):  # bounds that are not integers, a zero step
        raise StateError(f"rows: expected a slice of integer cycles, got {rows!r}") from None


def program_qdd(res: SimulationResult, rows: slice) -> NDArray:
    """The program's own acceleration [rad/s^2 | m/s^2] at the cycles ``rows`` of ``res``
    (:meth:`mrnea.simulate.SimulationResult.program_qdd`): ``(qd_cmd[k + 1] - qd_cmd[k]) /
    dt`` with the program's own next velocity after the last row (:func:`program_next`), the
    one kernels/simulate.py ``program_requirement`` computed ``program_effort`` for."""
    return _program_qdd(res, _cycles(res, rows))


def _program_qdd(res: SimulationResult, k: NDArray) -> NDArray:
    """:func:`program_qdd` at the cycles of the index array ``k``."""
    following = res.qd_cmd[np.minimum(k + 1, res.K - 1)]  # a copy (an index array)
    following[k + 1 >= res.K] = program_next(res)[1]
    return (following - res.qd_cmd[k]) / res.dt


def columns(res: SimulationResult, rows: slice) -> dict[str, NDArray]:
    """The per-cycle table of ``res`` at the cycles ``rows`` as named 1-D columns
    (:meth:`mrnea.simulate.SimulationResult.columns`, which lists them)."""
    k = _cycles(res, rows)  # the cycles a slice of the arrays holds, whatever its step
    cols: dict[str, NDArray] = {"t [s]": res.t[rows]}
    for attr, name, quantity in PER_JOINT:
        a = _program_qdd(res, k) if attr == "program_qdd" else getattr(res, attr)[rows]
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


def derive(res: SimulationResult, rows: slice, clamp: NDArray, resolution: NDArray) -> None:
    """Fill the derived per-cycle arrays of ``res`` at the rows (a chunk) the kernel has just
    computed (kernels/derived.py: the motor side of each cycle's effort at its starting speed
    [N m], the margin [N m | N], the tracking error [rad | m], the clamp flags; ``clamp``: the
    kernel's clamp codes; ``resolution``: (n,) the tracking errors that are rounding, see
    :attr:`mrnea.simulate.SimulationResult.tracking_error`)."""
    derived(compiled.of(res.robot)[3], (res.q_cmd, res.q, res.qd, res.tau, res.limit, clamp),
            (res.tau_motor, res.margin, res.tracking_error, res.position_clamped,
             res.velocity_clamped), resolution, rows.start, rows.stop)


def tool_errors(res: SimulationResult, rows: slice, path: CartesianPath) -> None:
    """Fill ``res``'s tool errors at ``rows`` (a run's chunk): the real motion's tool pose against
    the programmed one, position [m] and angle [rad] (:func:`mrnea.simulate.simulate`'s
    ``cartesian``)."""
    from scipy.spatial.transform import Rotation  # here, not at the top (io.posecsv)

    T = path.tool_poses(res.robot, res.q[rows], rows)
    P = path.pose[rows]
    res.tool_position_error[rows] = np.linalg.norm(T[:, :3, 3] - P[:, :3, 3], axis=1)
    res.tool_orientation_error[rows] = Rotation.from_matrix(
        np.transpose(P[:, :3, :3], (0, 2, 1)) @ T[:, :3, :3]).magnitude()


def csv_rows(res: SimulationResult, rows: slice, header: bool = False) -> bytes:
    """The table's ``rows`` as UTF-8 CSV, after the header row if ``header``."""
    buf = io.StringIO()
    writer = csv.writer(buf)
    cols = columns(res, rows)
    if header:
        writer.writerow(cols)
    writer.writerows(zip(*(c.tolist() for c in cols.values()), strict=True))
    return buf.getvalue().encode()
