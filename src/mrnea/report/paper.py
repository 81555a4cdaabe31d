"""The paper's Fig. 3: joint torques by the RNEA and by the mRNEA (``H qdd + u'``) along a
trajectory, and the input accelerations against those forward dynamics recovers."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import ArrayLike

from mrnea.errors import SingularMassMatrixError, StateError
from mrnea.report.drawing import MAX_JOINTS, axes_grid, header, joint_units, label, peak, plot_line
from mrnea.report.states import rigid_body_terms

if TYPE_CHECKING:
    from mrnea.model import Robot


def _solve_eq2(H: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """qdd (K, n) from ``H qdd = rhs`` (Eq. 2) for K mass matrices H (K, n, n) [kg m^2 | kg].

    Raises SingularMassMatrixError naming the first state whose H is not positive definite.
    """
    try:
        np.linalg.cholesky(H)  # the check forward_dynamics makes: H positive definite
    except np.linalg.LinAlgError:
        for k, Hk in enumerate(H):  # the first state whose factorisation fails
            try:
                np.linalg.cholesky(Hk)
            except np.linalg.LinAlgError:
                raise SingularMassMatrixError(f"fig3: the mass matrix H is not positive "
                                              f"definite at state {k}") from None
        raise
    return np.linalg.solve(H, rhs[..., None])[..., 0]


def fig3(robot: Robot, t: ArrayLike, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> Figure:
    """The paper's Fig. 3 for ``robot`` along a trajectory.

    (a) Joint torques ``u_i`` by the RNEA (:func:`mrnea.inverse_dynamics`, lines) and by the
    mRNEA, ``H qdd + u'`` from :func:`mrnea.mass_matrix_and_bias` (markers). (b) The input
    accelerations (lines) and those :func:`mrnea.forward_dynamics` recovers from the RNEA
    torques (markers), solving Eq. 2 ``H qdd = u - u'`` with the mRNEA's H and u' (what
    ``forward_dynamics(..., method="mrnea")`` does state by state; here one batched NumPy
    Cholesky check and solve, so a report compiles no forward-dynamics batch kernel: issue 22,
    docs/performance.md). The RNEA and the mRNEA run state by state on the kernels a
    simulation has compiled (:mod:`mrnea.report.states`: the public functions' values to the
    bit, nothing compiled after a run). The largest differences are printed in the titles.

    Parameters
    ----------
    robot : Robot
    t : (K,) array_like
        Time [s].
    q, qd, qdd : (K, n) array_like
        Joint positions, velocities and accelerations along the trajectory (SI units).

    Returns
    -------
    matplotlib.figure.Figure
        One row per joint; column (a) torques, column (b) accelerations.
    """
    for name, value in (("t", t), ("qdd", qdd)):  # q, qd: the dynamics functions check them
        try:
            kind = np.asarray(value).dtype.kind
        except (TypeError, ValueError):  # ragged
            kind = "O"
        if kind not in "iuf":
            raise StateError(f"{name}: expected an array of real numbers, got "
                             f"{type(value).__name__}")
    t = np.asarray(t, dtype=float)
    qdd = np.asarray(qdd, dtype=float)
    if t.ndim != 1 or qdd.ndim != 2 or qdd.shape[0] != t.shape[0]:
        raise StateError(f"fig3: expected t (K,) and q, qd, qdd (K, n); got t {t.shape}, "
                         f"qdd {qdd.shape}")
    u_rnea, H, u_bias = rigid_body_terms(robot, q, qd, qdd)
    u_mrnea = np.einsum("kij,kj->ki", H, qdd) + u_bias
    qdd_fd = _solve_eq2(H, u_rnea - u_bias)
    du = np.abs(u_rnea - u_mrnea)
    da = np.abs(qdd_fd - qdd)
    rel_u = float(du.max() / max(peak(u_rnea), 1e-300))
    rel_a = float(da.max() / max(peak(qdd), 1e-300))

    n, units = min(robot.n, MAX_JOINTS), joint_units(robot)  # the first MAX_JOINTS joints
    fig, axs = axes_grid(n, 2, 14.0, 1.7, top=1.15)
    every = max(1, t.shape[0] // 40)
    for i, (j, un) in enumerate(zip(robot.joints[:n], units[:n], strict=True)):
        a, b = axs[i]
        color = f"C{i % 10}"
        plot_line(a, t, u_rnea[:, i], color=color, lw=1.4)
        a.plot(t[::every], u_mrnea[::every, i], "o", ms=4, mfc="none", color="k", mew=0.9)
        plot_line(b, t, qdd[:, i], color=color, lw=1.4)
        b.plot(t[::every], qdd_fd[::every, i], "s", ms=4, mfc="none", color="k", mew=0.9)
        a.set_title(f"(a) {label(j.name)}: u  (max |Δu| = {float(du[:, i].max()):.2e} {un['tau']})",
                    fontsize="medium", loc="left")
        b.set_title(f"(b) {label(j.name)}: q̈  (max |Δq̈| = {float(da[:, i].max()):.2e} {un['qdd']})",
                    fontsize="medium", loc="left")
        a.set_ylabel(f"u [{un['tau']}]")
        b.set_ylabel(f"q̈ [{un['qdd']}]")
        for ax in (a, b):
            ax.grid(True, alpha=0.3)
    for ax in axs[-1]:
        ax.set_xlabel("time t [s]")
    header(fig, (
        f"Fig. 3, {label(robot.name)}: (a) joint torques, RNEA vs mRNEA: max difference "
        f"{du.max():.3e} (relative {rel_u:.3e})\n(b) input accelerations vs forward dynamics: "
        f"max difference {da.max():.3e} (relative {rel_a:.3e})"), [
        Line2D([], [], color="0.3", lw=1.4, label="(a) RNEA: inverse_dynamics"),
        Line2D([], [], color="k", marker="o", mfc="none", ls="", label="(a) mRNEA: H q̈ + u'"),
        Line2D([], [], color="0.3", lw=1.4, label="(b) input q̈"),
        Line2D([], [], color="k", marker="s", mfc="none", ls="",
               label="(b) q̈ solving H q̈ = u_RNEA - u' (Eq. 2)"),
    ])
    return fig
