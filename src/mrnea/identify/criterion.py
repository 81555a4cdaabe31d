"""The excitation criterion: the condition number of the base regressor stacked over a time
grid, and its gradient with respect to the joint states, for :mod:`mrnea.identify.excite`.

Over K samples ``(q_k, qd_k, qdd_k)`` the base regressor ``W_b`` (K n, r) is the stack of
``W(q_k, qd_k, qdd_k)[:, columns]`` (:func:`mrnea.identify.base.full_regressor`, the base
columns of :class:`~mrnea.identify.base.BaseParameters`). Its columns are scaled to unit norm,
``W_s = W_b D^-1``, ``D = diag(|w_c|)``, as :func:`mrnea.identify.identify` reports it, so the
number does not depend on the parameters' units (kg against kg m^2). The criterion is

    f = log cond(W_s) = log s_1 - log s_r                 (s: singular values of W_s)

with ``df = <G, dW_s>``, ``G = u_1 v_1^T / s_1 - u_r v_r^T / s_r``; through the scaling,
``<G, dW_s> = <G', dW_b>`` with ``G'_c = G_c / d_c - w_c (w_c . G_c) / d_c^3``.

``dW/dq_j, dW/dqd_j, dW/dqdd_j`` per sample: the rigid-body part Y is linear in qdd and
quadratic in qd, so a central difference with a unit step is exact in those two (up to
rounding); in q it is a central difference with step ``H_Q`` (error ~ H_Q^2). The drive columns
``[qdd_j, qd_j, [qd_j > 0], -[qd_j < 0], 1]`` (:func:`mrnea.identify.actuator_regressor`) have
the derivatives 1 (column ``5 j``, by qdd_j) and 1 (column ``5 j + 1``, by qd_j); the Coulomb
columns are constant where qd_j != 0.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from mrnea.identify.base import BaseParameters, full_regressor
from mrnea.identify.regressor import regressor
from mrnea.model import Robot

H_Q = 1e-6  # [rad | m] step of the central difference in q


def condition(W: NDArray) -> float:
    """cond of W (rows, r) with its columns scaled to unit norm (the module docstring); inf
    where a column is zero (a parameter the motion does not excite)."""
    d = np.linalg.norm(W, axis=0)
    return float(np.linalg.cond(W / d)) if np.all(d > 0) else math.inf


def stacked(robot: Robot, base: BaseParameters, q: NDArray, qd: NDArray, qdd: NDArray
            ) -> NDArray[np.float64]:
    """W_b (K n, r): the base regressor stacked over the K samples (K, n) of q, qd, qdd."""
    return base.reduce(full_regressor(robot, q, qd, qdd)).reshape(-1, base.r)


def derivatives(robot: Robot, q: NDArray, qd: NDArray, qdd: NDArray
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(W, dW): the full regressor ``W`` (K, n, 15 n) and its derivatives ``dW`` (K, 3, n, n,
    15 n), ``dW[k, v, j]`` = dW_k / d(q, qd, qdd)[v]_j (the module docstring)."""
    K, n = q.shape
    steps = np.array([H_Q, 1.0, 1.0])
    E = np.eye(n)
    # states (K, 3, 2, n, n): variable v of joint j moved by + and - its step
    Q = np.broadcast_to(q[:, None, None, None, :], (K, 3, 2, n, n)).copy()
    QD = np.broadcast_to(qd[:, None, None, None, :], (K, 3, 2, n, n)).copy()
    QDD = np.broadcast_to(qdd[:, None, None, None, :], (K, 3, 2, n, n)).copy()
    for v, X in enumerate((Q, QD, QDD)):
        X[:, v, 0] += steps[v] * E
        X[:, v, 1] -= steps[v] * E
    Y = regressor(robot, Q.reshape(-1, n), QD.reshape(-1, n), QDD.reshape(-1, n))
    Y = Y.reshape(K, 3, 2, n, n, 10 * n)
    dW = np.zeros((K, 3, n, n, 15 * n))
    dW[..., :10 * n] = (Y[:, :, 0] - Y[:, :, 1]) / (2 * steps[None, :, None, None, None])
    j = np.arange(n)
    dW[:, 1, j, j, 10 * n + 5 * j + 1] = 1.0  # F_v qd_j
    dW[:, 2, j, j, 10 * n + 5 * j] = 1.0  # G^2 J_m qdd_j
    return full_regressor(robot, q, qd, qdd), dW


def log_condition(W: NDArray, base: BaseParameters, dW: NDArray | None = None
                  ) -> tuple[float, NDArray[np.float64] | None]:
    """f = log cond(W_s) of the full regressor W (K, n, 15 n) through the base columns, and,
    with ``dW`` (:func:`derivatives`), df/d(q, qd, qdd) (K, 3, n); else None."""
    K, n = W.shape[:2]
    Wb = base.reduce(W).reshape(K * n, base.r)
    d = np.linalg.norm(Wb, axis=0)
    if not np.all(d > 0):  # a column the motion does not excite (no gradient asked there)
        return math.inf, None if dW is None else np.zeros((K, 3, n))
    U, s, Vt = np.linalg.svd(Wb / d, full_matrices=False)
    f = float(np.log(s[0] / s[-1])) if s[-1] > 0 else math.inf
    if dW is None:
        return f, None
    G = np.outer(U[:, 0], Vt[0]) / s[0] - np.outer(U[:, -1], Vt[-1]) / s[-1]
    G = G / d - Wb * (np.einsum("ic,ic->c", Wb, G) / d ** 3)  # G' of the module docstring
    G = G.reshape(K, n, base.r)
    return f, np.einsum("kic,kvjic->kvj", G, base.reduce(dW))
