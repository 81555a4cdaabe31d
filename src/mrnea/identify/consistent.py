"""Physically consistent parameters: each link's 10 parameters through the log-Cholesky
factor of its pseudo-inertia (Rucker and Wensing 2022), so that every candidate is a rigid body.

The pseudo-inertia of a link, about its origin, link frame::

    J = [[Sigma, h], [h^T, m]],   Sigma = tr(I) / 2 1 - I   (I about the origin, h = m c)

is positive definite exactly when the mass is positive and the inertia about the centre of mass
is positive definite with the triangle inequality (a density can make it). With
``J = U U^T``, ``U = e^alpha [[e^d1, s12, s13, t1], [0, e^d2, s23, t2], [0, 0, e^d3, t3],
[0, 0, 0, 1]]``, the 10 unconstrained numbers ``[alpha, d1, d2, d3, s12, s23, s13, t1, t2, t3]``
map one to one onto the physically consistent links.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mrnea.identify.regressor import split_link_parameters

EXP_MAX = 50.0  # a log-Cholesky exponent is clipped here (an optimiser's trial step, not a body)
_SYM = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))


def pseudo_inertia(p: NDArray) -> NDArray[np.float64]:
    """J (4, 4) of a link's 10 parameters (module docstring)."""
    inertia_o = np.zeros((3, 3))
    for v, (a, b) in zip(p[4:], _SYM, strict=True):
        inertia_o[a, b] = inertia_o[b, a] = v
    J = np.zeros((4, 4))
    J[:3, :3] = np.trace(inertia_o) / 2 * np.eye(3) - inertia_o
    J[:3, 3] = J[3, :3] = p[1:4]
    J[3, 3] = p[0]
    return J


def parameters_of_pseudo(J: NDArray) -> NDArray[np.float64]:
    """The 10 parameters of a pseudo-inertia J (4, 4)."""
    tr = J[0, 0] + J[1, 1] + J[2, 2]  # I = tr(Sigma) 1 - Sigma
    return np.array([J[3, 3], J[0, 3], J[1, 3], J[2, 3], tr - J[0, 0], -J[0, 1], tr - J[1, 1],
                     -J[0, 2], -J[1, 2], tr - J[2, 2]])


# where each log-Cholesky number (after alpha) sits in U: d1..d3 on the diagonal, then s12, s23,
# s13, t1, t2, t3
_ENTRY = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))


def _factor(x: NDArray) -> NDArray[np.float64]:
    """U (4, 4) of the 10 log-Cholesky numbers x (module docstring)."""
    U = np.zeros((4, 4))
    U[3, 3] = 1.0
    for k, (a, b) in enumerate(_ENTRY):
        U[a, b] = np.exp(min(x[1 + k], EXP_MAX)) if a == b else x[1 + k]
    return np.exp(min(x[0], EXP_MAX)) * U


def from_log_cholesky(x: NDArray) -> NDArray[np.float64]:
    """A link's 10 parameters of its 10 log-Cholesky numbers (module docstring)."""
    U = _factor(x)
    return parameters_of_pseudo(U @ U.T)


def log_cholesky_jacobian(x: NDArray) -> NDArray[np.float64]:
    """d parameters / d x (10, 10) at x: ``dJ = dU U^T + U dU^T``, ``dU/dalpha = U``,
    ``dU/dd_i = U_ii E_ii``, ``dU/ds = e^alpha E`` (the parameters are linear in J)."""
    U = _factor(x)
    out = np.empty((10, 10))
    for k in range(10):
        dU = np.zeros((4, 4))
        if k == 0:
            dU = U
        else:
            a, b = _ENTRY[k - 1]
            dU[a, b] = U[a, b] if a == b else np.exp(x[0])
        out[:, k] = parameters_of_pseudo(dU @ U.T + U @ dU.T)
    return out


def to_log_cholesky(p: NDArray, floor: float) -> NDArray[np.float64]:
    """The log-Cholesky numbers of a link's parameters p; a pseudo-inertia that is not positive
    definite (a massless link, a flat one) is first lifted to its eigenvalues >= ``floor``."""
    J = pseudo_inertia(p)
    w, V = np.linalg.eigh(J)
    J = (V * np.maximum(w, floor)) @ V.T
    P = np.eye(4)[::-1]  # U U^T = J with U upper triangular: the Cholesky factor of P J P
    U = P @ np.linalg.cholesky(P @ J @ P) @ P
    e = U[3, 3]
    return np.array([np.log(e), *np.log(np.diag(U)[:3] / e), U[0, 1] / e, U[1, 2] / e,
                     U[0, 2] / e, *(U[:3, 3] / e)])


def is_consistent(p: NDArray, rtol: float = 1e-12) -> bool:
    """Mass > 0, the inertia about the centre of mass positive semi-definite, with the triangle
    inequality ``I_a + I_b >= I_c`` on its principal moments, each to ``rtol`` times the largest
    moment (rounding: a flat body, on the boundary, computes its moments a few ulps off)."""
    m, _, inertia_c = split_link_parameters(p)
    if not m > 0:
        return False
    e = np.linalg.eigvalsh((inertia_c + inertia_c.T) / 2)
    tol = rtol * max(abs(e[2]), abs(e[0]))
    return bool(e[0] >= -tol and e[0] + e[1] >= e[2] - tol)
