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

:class:`Problem` is the optimisation of :mod:`mrnea.identify.excite` over one joint's Fourier
free numbers (:func:`basis`): the criterion at ``samples`` instants of a period, the linear
position, velocity and acceleration constraints and the effort constraints (tau = W theta), with
their Jacobians, solved by SLSQP.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mrnea.identify.base import BaseParameters, full_regressor
from mrnea.identify.fourier import coefficients, evaluate
from mrnea.identify.regressor import actuator_parameters, inertial_parameters, regressor
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


@dataclass(frozen=True)
class Limits:
    """What the excitation keeps within, per joint (n,): positions ``lower``, ``upper`` [rad | m],
    ``velocity`` [rad/s | m/s], ``acceleration`` [rad/s^2 | m/s^2] (inf: none) and ``effort``
    [N m | N] (``effort_margin`` times the robot's effort limit; inf: none)."""

    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    effort: NDArray[np.float64]


def basis(harmonics: int, base_frequency: float, t: NDArray) -> NDArray[np.float64]:
    """(3, K, m): q, qd, qdd at times t [s] of each of one joint's m = 2 L - 1 free numbers
    (:func:`mrnea.identify.fourier.coefficients`): ``q_j(t) = B[0] @ x_j``."""
    m = 2 * harmonics - 1
    c, a, b = coefficients(np.eye(m), m, harmonics)
    return np.stack(evaluate(c, a, b, base_frequency, t))


class Problem:
    """The optimisation of the module docstring: the criterion, the constraints and their
    derivatives at the ``samples`` instants of one period, for the free numbers x (n m,)."""

    def __init__(self, robot: Robot, base: BaseParameters, limits: Limits, harmonics: int,
                 base_frequency: float, samples: int) -> None:
        self.robot, self.base, self.limits = robot, base, limits
        self.n, self.m = robot.n, 2 * harmonics - 1
        self.theta = np.concatenate([inertial_parameters(robot), actuator_parameters(robot)])
        self.B = basis(harmonics, base_frequency, np.arange(samples) / (samples * base_frequency))
        self._W: tuple[bytes, NDArray] | None = None  # x and W of the last call
        self._dW: tuple[bytes, NDArray, NDArray] | None = None  # x, W and dW of the last call
        self.A, self.b = self._linear()

    def states(self, x: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        X = x.reshape(self.n, self.m)
        return self.B[0] @ X.T, self.B[1] @ X.T, self.B[2] @ X.T

    def regressor(self, x: NDArray) -> NDArray:
        """W (K, n, 15 n) at the instants (cached for the last x)."""
        if self._W is None or self._W[0] != x.tobytes():
            self._W = (x.tobytes(), full_regressor(self.robot, *self.states(x)))
        return self._W[1]

    def derivatives(self, x: NDArray) -> tuple[NDArray, NDArray]:
        """W and dW (K, 3, n, n, 15 n) at the instants (cached for the last x)."""
        if self._dW is None or self._dW[0] != x.tobytes():
            self._dW = (x.tobytes(), *derivatives(self.robot, *self.states(x)))
        return self._dW[1], self._dW[2]

    def value(self, x: NDArray) -> float:
        """The criterion, log cond (the line search's calls: no derivatives)."""
        return log_condition(self.regressor(x), self.base)[0]

    def gradient(self, x: NDArray) -> NDArray:
        """d log cond / dx (n m,)."""
        W, dW = self.derivatives(x)
        g = log_condition(W, self.base, dW)[1]
        return np.einsum("vkm,kvj->jm", self.B, g).ravel()

    def _linear(self) -> tuple[NDArray, NDArray]:
        """``A x >= b``: the position, velocity and acceleration limits at every instant."""
        lim, (n, m), K = self.limits, (self.n, self.m), self.B.shape[1]
        rows, rhs = [], []
        for j in range(n):
            bounds = ((lim.lower[j], lim.upper[j]), (-lim.velocity[j], lim.velocity[j]),
                      (-lim.acceleration[j], lim.acceleration[j]))
            for v, (low, high) in enumerate(bounds):
                for sign, bound in ((1.0, low), (-1.0, -high)):
                    if np.isfinite(bound):
                        A = np.zeros((K, n * m))
                        A[:, j * m:(j + 1) * m] = sign * self.B[v]
                        rows.append(A)
                        rhs.append(np.full(K, bound))
        return np.vstack(rows), np.concatenate(rhs)

    def efforts(self, x: NDArray) -> NDArray:
        """``e - tau >= 0`` and ``e + tau >= 0`` for every finite effort limit e at every
        instant (tau = W theta)."""
        finite = np.isfinite(self.limits.effort)
        tau = (self.regressor(x) @ self.theta)[:, finite]
        e = self.limits.effort[finite]
        return np.concatenate([(e - tau).ravel(), (e + tau).ravel()])

    def efforts_jacobian(self, x: NDArray) -> NDArray:
        """d :meth:`efforts` / dx."""
        dtau = self.derivatives(x)[1] @ self.theta  # (K, 3, n, n): d tau_i / d(q, qd, qdd)_j
        J = np.einsum("vkm,kvji->kijm", self.B, dtau)[:, np.isfinite(self.limits.effort)]
        J = J.reshape(-1, self.n * self.m)
        return np.vstack([-J, J])

    def solve(self, x0: NDArray, maxiter: int, checkpoint: Callable[[], None]) -> NDArray:
        """SLSQP from x0; the free numbers it ends at (``checkpoint`` called every
        iteration)."""
        constraints = [{"type": "ineq", "fun": lambda x: self.A @ x - self.b,
                        "jac": lambda x: self.A}]
        if np.any(np.isfinite(self.limits.effort)):
            constraints.append({"type": "ineq", "fun": self.efforts,
                                "jac": self.efforts_jacobian})
        bounds = [(lo, hi) if i == 0 else (None, None)
                  for lo, hi in zip(self.limits.lower, self.limits.upper, strict=True)
                  for i in range(self.m)]
        import scipy.optimize  # here, not at the top: every command imports this module

        res = scipy.optimize.minimize(self.value, x0, jac=self.gradient, method="SLSQP",
                                      bounds=bounds, constraints=constraints,
                                      options={"maxiter": maxiter},
                                      callback=lambda xk: checkpoint())
        return res.x
