"""The rigid-body terms and link frames a report draws, one state at a time on the kernels a
simulation has compiled already.

Fig. 3 (:func:`mrnea.report.fig3`) and the 3D view (:func:`mrnea.report.view3d.result_scene`)
evaluate a few thousand states of a run. The public batch functions
(:func:`mrnea.inverse_dynamics`, :func:`mrnea.mass_matrix_and_bias`,
:func:`mrnea.forward_kinematics`) run them as ``parallel=True`` kernels, whose compiling (parfor
lowering, the mRNEA call tree optimised once more under each) cost a fresh ``mrnea demo`` about
9 s of its first run for work that takes milliseconds (issue 22, docs/performance.md). Here each
state is one call, from Python, of a single-state kernel with exactly the argument types the
simulation loop called it with, so Numba finds it compiled (in this process or its disk cache)
and compiles nothing:

* the RNEA, u = ID(q, qd, qdd): ``kernels.rnea.rnea_ws`` as ``kernels.simulate.program_requirement``
  calls it (C-contiguous rows, no ``pose_ready``);
* H and u' by the mRNEA (the paper's symmetric fill, ``ENGINE_MRNEA``):
  ``kernels.drive.actuator_terms`` as :func:`mrnea.simulate`'s start check calls it, with an
  actuator array of zeros, so that its H_a = H + diag(G^2 J_m) and u'_a = u' + F_v qd add
  exact zeros: H and u' to the bit;
* the frames: ``kernels.kinematics.frames_ws``, the body of the batch kernel (the only new
  compile, under a second: it links the kinematics pass the RNEA compiled).

The values are those of the public functions to the bit (the same compiled code, the same
operations; tests/test_report_states.py checks them against Pinocchio and against the public
batch functions). No wrench: a report's rigid-body terms are those of the free motion, as
:func:`mrnea.report.fig3` documents. At a few microseconds a state the loop costs
milliseconds; the public batch functions stay the parallel kernels for library users.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import compiled, validate
from mrnea.kernels.drive import actuator_terms
from mrnea.kernels.engines import ENGINE_MRNEA
from mrnea.kernels.kinematics import frames_ws
from mrnea.kernels.layout import NACT
from mrnea.kernels.rnea import rnea_ws

if TYPE_CHECKING:
    from mrnea.model import Robot

_NO_DRIVE: dict[int, NDArray[np.float64]] = {}  # n: a read-only (n, NACT) array of zeros


def _no_drive(n: int) -> NDArray[np.float64]:
    """An actuator array (kernels/layout.py) without gear, rotor or viscous friction: read-only,
    as the compiled ones, so that ``actuator_terms`` is called with the types it was compiled
    for."""
    act = _NO_DRIVE.get(n)
    if act is None:
        act = np.zeros((n, NACT))
        act.flags.writeable = False
        act = _NO_DRIVE.setdefault(n, act)
    return act


def rigid_body_terms(robot: Robot, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The RNEA's efforts and the mRNEA's H and u' along K states, one state at a time
    (module docstring), without an external wrench.

    Parameters
    ----------
    robot : Robot
    q, qd, qdd : (n,) or (K, n) array_like
        Joint positions [rad | m], velocities [rad/s | m/s], accelerations [rad/s^2 | m/s^2];
        at least one of them (K, n).

    Returns
    -------
    u : (K, n) the efforts ID(q, qd, qdd) [N m | N] (:func:`mrnea.inverse_dynamics`).
    H : (K, n, n) the mass matrix [kg m^2 | kg]; u' : (K, n) the bias [N m | N]
        (:func:`mrnea.mass_matrix_and_bias`, ``method="mrnea"``): u = H qdd + u'.

    Raises
    ------
    StateError
        As the public functions: a shape, NaN or inf named, or values too large.
    """
    states = {"q": q, "qd": qd, "qdd": qdd}
    _, arrays, _, _ = validate.inputs(robot, states, None, None)
    Q, QD, QDD = (np.atleast_2d(a) for a in arrays)
    m, _, ws, _ = compiled.of(robot)
    act = _no_drive(robot.n)
    K, n = Q.shape
    FE, PE = np.zeros((K, 6)), np.zeros((K, 3))  # no wrench; rows as the simulation's program
    u, H, ub = np.empty((K, n)), np.empty((K, n, n)), np.empty((K, n))
    st_u, st_h = np.empty(K, dtype=np.int64), np.empty(K, dtype=np.int64)
    for k in range(K):
        st_u[k] = rnea_ws(m, Q[k], QD[k], QDD[k], FE[k], PE[k], u[k], ws, False)  # a bool, as
        # program_requirement passes: one compiled rnea_ws
        st_h[k] = actuator_terms(m, act, Q[k], QD[k], FE[k], PE[k], ENGINE_MRNEA, H[k], ub[k],
                                 ws)
    validate.check_status(robot, st_u, states)
    validate.check_status(robot, st_h, {"q": q, "qd": qd})
    return u, H, ub


def link_frames(robot: Robot, q: ArrayLike) -> NDArray[np.float64]:
    """The base's and every link's frame along K states, one state at a time (module
    docstring): (K, n + 1, 4, 4), as :func:`mrnea.forward_kinematics` of q (K, n) [rad | m]."""
    _, Q, _ = validate.kinematics_inputs(robot, q, None)
    Q = np.atleast_2d(Q)
    m, _, ws, _ = compiled.of(robot)
    T = np.empty((Q.shape[0], robot.n + 1, 4, 4))
    status = np.empty(Q.shape[0], dtype=np.int64)
    for k in range(Q.shape[0]):
        status[k] = frames_ws(m, Q[k], T[k], ws)
    validate.check_status(robot, status, {"q": q})
    return T
