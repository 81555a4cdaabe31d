"""The paper's cost comparison: H and u' by one of three engines, and forward dynamics through them.

Usage: ``status = mass_matrix_bias(model, q, qd, fext, pe, engine, H, u, ws)`` fills H (n, n) and
u' (n,) by the paper's mRNEA (``ENGINE_MRNEA``, kernels/mrnea.py), Walker-Orin method 1
(``ENGINE_WALKER_ORIN``, kernels/walker_orin.py) or CRBA with one Newton-Euler pass for the bias
(``ENGINE_CRBA``, kernels/crba.py), the engine a compile-time choice (its type, below);
``status = fd_walker_orin(model, q, qd, tau, fext, pe, qdd, ws)`` and ``fd_crba`` solve
``H qdd = tau - u'`` (Eq. 2) on H and u' of those engines (``fd_mrnea``, the paper's, is in
kernels/mrnea.py). The batch kernels of both take the engine as an argument (compiled once per
engine used), so that the public API runs every engine's batch through the same two loops:
``mass_matrix_bias_batch(model, Q, QD, FEXT, PE, H, U, STATUS, ws, engine)`` and
``fd_batch(model, Q, QD, TAU, FEXT, PE, QDD, STATUS, ws, engine)`` (ABA, which forms no H, has
its own, kernels/aba.py). ``ws``: a ``SOLVE`` scratch, or a ``batch_scratch`` for the batch
kernels (kernels/layout.py).
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
from numba.extending import overload

from mrnea.kernels.common import sized
from mrnea.kernels.crba import crba_bias
from mrnea.kernels.layout import ENTRY_ALLOC, JIT, PARALLEL, own_scratch, solve_buffers
from mrnea.kernels.mrnea import mrnea_ws
from mrnea.kernels.solve import solve_forward
from mrnea.kernels.status import SIZE
from mrnea.kernels.walker_orin import walker_orin


# The engine is a compile-time choice: each is a one-field named tuple of its own class, so
# Numba types it by its class and compiles a kernel that takes one for that engine alone
# (``mass_matrix_bias``'s overload picks the engine while typing). A run-time integer compiled
# all three into every kernel above it although a command uses one: a fresh ``mrnea demo``
# compiled Walker-Orin and CRBA for nothing (docs/performance.md, Start-up). The field keeps
# ``engine == ENGINE_MRNEA`` meaningful in compiled code (named tuples compare by value).
class Mrnea(NamedTuple):
    """The paper's mRNEA (kernels/mrnea.py)."""
    code: int


class WalkerOrin(NamedTuple):
    """Walker-Orin method 1 (kernels/walker_orin.py)."""
    code: int


class Crba(NamedTuple):
    """CRBA and one Newton-Euler pass for the bias (kernels/crba.py)."""
    code: int


ENGINE_MRNEA, ENGINE_WALKER_ORIN, ENGINE_CRBA = Mrnea(0), WalkerOrin(1), Crba(2)


def mass_matrix_bias(model, q, qd, fext, pe, engine, H, u, ws):
    """H (n, n) and u' (n,) of one state by ``engine``; returns a status (as ``mrnea``). In
    compiled code its overload (below) compiles the one engine ``engine``'s type names; this
    body serves Python (NUMBA_DISABLE_JIT)."""
    if engine == ENGINE_WALKER_ORIN:
        return walker_orin(model, q, qd, fext, pe, H, u, ws)
    if engine == ENGINE_CRBA:
        return crba_bias(model, q, qd, fext, pe, H, u, ws)
    return mrnea_ws(model, q, qd, fext, pe, H, u, False, ws)


@overload(mass_matrix_bias, inline="always")
def _mass_matrix_bias(model, q, qd, fext, pe, engine, H, u, ws):
    """The engine of ``engine``'s type, chosen while typing: only its kernel is compiled."""
    kind = getattr(engine, "instance_class", None)
    if kind is WalkerOrin:
        return lambda model, q, qd, fext, pe, engine, H, u, ws: walker_orin(
            model, q, qd, fext, pe, H, u, ws)
    if kind is Crba:
        return lambda model, q, qd, fext, pe, engine, H, u, ws: crba_bias(
            model, q, qd, fext, pe, H, u, ws)
    if kind is Mrnea:
        return lambda model, q, qd, fext, pe, engine, H, u, ws: mrnea_ws(
            model, q, qd, fext, pe, H, u, False, ws)
    return None  # not an engine: a typing error


@nb.njit(**JIT)
def fd_engine(model, q, qd, tau, fext, pe, qdd, engine, ws):
    """Forward dynamics of one state on H and u' of ``engine``, after checking the state's
    lengths (status SIZE): H qdd = tau - u' by a Cholesky solve (Eq. 2)."""
    if not sized(model, q, qd, tau):
        return SIZE
    H, L, u, rhs = solve_buffers(ws, q.shape[0])
    status = mass_matrix_bias(model, q, qd, fext, pe, engine, H, u, ws)
    return solve_forward(model, status, H, u, tau, L, rhs, qdd)


@nb.njit(**ENTRY_ALLOC)
def fd_walker_orin(model, q, qd, tau, fext, pe, qdd, ws):
    """Forward dynamics by Walker-Orin method 1 and a Cholesky solve; returns a status."""
    return fd_engine(model, q, qd, tau, fext, pe, qdd, ENGINE_WALKER_ORIN, ws)


@nb.njit(**ENTRY_ALLOC)
def fd_crba(model, q, qd, tau, fext, pe, qdd, ws):
    """Forward dynamics: H by CRBA, the bias by one RNEA with qdd = 0, then a Cholesky solve."""
    return fd_engine(model, q, qd, tau, fext, pe, qdd, ENGINE_CRBA, ws)


@nb.njit(**PARALLEL)
def mass_matrix_bias_batch(model, Q, QD, FEXT, PE, H, U, STATUS, ws, engine):
    """``mass_matrix_bias`` over a batch: Q, QD, U (B, n); FEXT (B, 6); PE (B, 3); H (B, n, n);
    STATUS (B,) int64; ws: a ``batch_scratch`` (kernels/layout.py)."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = mass_matrix_bias(model, Q[b], QD[b], FEXT[b], PE[b], engine, H[b], U[b],
                                     own_scratch(ws))


@nb.njit(**PARALLEL)
def fd_batch(model, Q, QD, TAU, FEXT, PE, QDD, STATUS, ws, engine):
    """``fd_engine`` over a batch: TAU, QDD (B, n); the others as ``mass_matrix_bias_batch``."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = fd_engine(model, Q[b], QD[b], TAU[b], FEXT[b], PE[b], QDD[b], engine,
                              own_scratch(ws))
