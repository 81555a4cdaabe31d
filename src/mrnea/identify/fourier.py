"""Finite Fourier series per joint (Swevers et al. 1997), periodic and at rest where it starts:

    q_j(t) = c_j + sum_{l=1..L} a_jl sin(l w t) + b_jl cos(l w t),    w = 2 pi f (base frequency)

At rest at t = 0 (so at every whole period): ``qd_j(0) = w sum_l l a_jl = 0`` and
``qdd_j(0) = -w^2 sum_l l^2 b_jl = 0``, kept by computing the first harmonic from the others:
``a_j1 = -sum_{l>=2} l a_jl``, ``b_j1 = -sum_{l>=2} l^2 b_jl``. The free numbers per joint are
``c_j`` and ``a_jl, b_jl`` for l = 2..L (:func:`coefficients` completes them).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def coefficients(free: NDArray, n: int, harmonics: int) -> tuple[NDArray, NDArray, NDArray]:
    """(c (n,), a (n, L), b (n, L)) of the free numbers ``free``, (n, 1 + 2 (L - 1)) or flat."""
    x = np.asarray(free, dtype=float).reshape(n, 1 + 2 * (harmonics - 1))
    ell = np.arange(2, harmonics + 1)
    a, b = np.zeros((n, harmonics)), np.zeros((n, harmonics))
    a[:, 1:], b[:, 1:] = x[:, 1:harmonics], x[:, harmonics:]
    a[:, 0] = -(a[:, 1:] * ell).sum(axis=1)
    b[:, 0] = -(b[:, 1:] * ell ** 2).sum(axis=1)
    return x[:, 0], a, b


def evaluate(c: NDArray, a: NDArray, b: NDArray, base_frequency: float, t: NDArray
             ) -> tuple[NDArray, NDArray, NDArray]:
    """q, qd, qdd (K, n) at times t (K,) [s]; base_frequency [Hz]."""
    w = 2 * np.pi * base_frequency * np.arange(1, a.shape[1] + 1)  # (L,)
    s, co = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))  # (K, L)
    q = c + s @ a.T + co @ b.T
    qd = (co * w) @ a.T - (s * w) @ b.T
    qdd = -(s * w ** 2) @ a.T - (co * w ** 2) @ b.T
    return q, qd, qdd
