"""Base parameters: the identifiable combinations of the inertial and actuator parameters,
found numerically (Gautier 1990; Gautier and Khalil's base parameters by QR).

The full parameter vector ``theta = [pi; a]`` (15 n,: the 10 inertial parameters per link, then
the 5 actuator parameters per joint, :mod:`mrnea.identify.regressor`) is not identifiable: some
columns of the stacked regressor ``W = [Y, A]`` are zero for every motion (a link's mass seen by
no joint) or combinations of others (the mass of link i+1 at the axis of joint i+1 acts like
link i's). On ``STATES`` random states (q uniform within the position limits, else in
[-pi, pi] rad or [-0.5, 0.5] m; qd, qdd standard normal) the QR decomposition of W, without
pivoting, keeps column k when its part orthogonal to the columns kept before it is larger than
``RANK_TOL`` times the column's norm (a column whose norm is below ``RANK_TOL`` times the
largest is zero: only rounding). So the base parameters are the first independent columns
in the documented order (the earlier link's, and the rigid body's before the drive's), and the
rank is checked against the SVD's. The others are written as
``W_dependent = W_base B`` (least squares, exact to rounding), so that

    W theta = W_base beta,    beta = K theta,    K = [1  B] (columns in theta's order).

Notes: an offset and an asymmetric Coulomb pair are one parameter too many for a moving joint
(``[qd > 0] + [qd < 0] = 1``): the offset folds into ``F+`` and ``F-`` (``F+ + o``,
``F- - o``). Where joint 1 turns about the vertical, the rotor inertia of joint 1 folds into
link 1's ``I_zz`` (both are seen through qdd_1 alone).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mrnea.identify.regressor import (
    ACTUATOR_NAMES,
    INERTIAL_NAMES,
    actuator_regressor,
    regressor,
    require_serial,
)
from mrnea.model import Robot

STATES = 200  # random states the columns are tested on
RANK_TOL = 1e-9  # relative norm of a column's new direction below which it is dependent


@dataclass(frozen=True)
class BaseParameters:
    """The base parameters of a robot: ``beta = K theta`` (r,) from theta (15 n,).

    ``columns`` (r,): the indices into theta of the base columns; ``K`` (r, 15 n); ``names``
    (15 n,): the name of each parameter of theta, e.g. ``"link3.m"``, ``"joint2.viscous"``.
    """

    columns: NDArray[np.int64]
    K: NDArray[np.float64]
    names: tuple[str, ...]

    @property
    def r(self) -> int:
        return len(self.columns)

    def base_names(self) -> list[str]:
        """Each base parameter's name: its own column's, with ``+ ...`` when others fold in."""
        out = []
        for row, col in zip(self.K, self.columns, strict=True):
            extra = np.count_nonzero(np.abs(row) > 1e-12) - 1
            out.append(self.names[col] + (f" (+{extra})" if extra else ""))
        return out

    def reduce(self, W: NDArray[np.float64]) -> NDArray[np.float64]:
        """The base columns of a full regressor W (..., 15 n)."""
        return W[..., self.columns]


def full_regressor(robot: Robot, q: NDArray, qd: NDArray, qdd: NDArray) -> NDArray[np.float64]:
    """``W = [Y, A]`` (..., n, 15 n): the rigid-body and the actuator columns."""
    return np.concatenate([regressor(robot, q, qd, qdd), actuator_regressor(robot, qd, qdd)],
                          axis=-1)


def parameter_names(robot: Robot) -> tuple[str, ...]:
    """Names of theta's entries: ``<link>.<m|mcx|...>``, then ``<joint>.<rotor|viscous|...>``."""
    return (tuple(f"{lk}.{p}" for lk in robot.link_names for p in INERTIAL_NAMES)
            + tuple(f"{j}.{p}" for j in robot.joint_names for p in ACTUATOR_NAMES))


def random_states(robot: Robot, count: int, seed: int = 0) -> tuple[NDArray, NDArray, NDArray]:
    """``count`` random states (the module docstring), (count, n) each."""
    rng = np.random.default_rng(seed)
    n = robot.n
    span = np.where(robot.is_prismatic, 0.5, np.pi)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -span)
    hi = np.where(np.isfinite(robot.upper), robot.upper, span)
    return (rng.uniform(lo, hi, size=(count, n)), rng.normal(size=(count, n)),
            rng.normal(size=(count, n)))


def base_parameters(robot: Robot, seed: int = 0) -> BaseParameters:
    """The base parameters of ``robot`` (module docstring), from ``STATES`` random states."""
    require_serial(robot, "base_parameters")
    W = full_regressor(robot, *random_states(robot, STATES, seed)).reshape(-1, 15 * robot.n)
    norms = np.linalg.norm(W, axis=0)
    norms[norms <= RANK_TOL * norms.max()] = np.inf  # a zero column, to rounding
    import scipy.linalg  # here, not at the top: every command imports this module

    R = scipy.linalg.qr(W, mode="r")[0]
    keep = np.flatnonzero(np.abs(np.diag(R)) > RANK_TOL * norms)
    rank = np.linalg.matrix_rank(R / norms, tol=RANK_TOL)  # R: W's singular values
    if len(keep) != rank:  # pragma: no cover - a state set that hides a direction
        raise RuntimeError(f"base_parameters: {len(keep)} columns kept, rank {rank}")
    dep = np.setdiff1d(np.arange(W.shape[1]), keep)
    K = np.zeros((len(keep), W.shape[1]))
    K[:, keep] = np.eye(len(keep))
    if len(dep):
        B = np.linalg.lstsq(W[:, keep], W[:, dep], rcond=None)[0]
        B[np.abs(B) < 1e-10 * max(1.0, np.abs(B).max())] = 0.0  # rounding of exact zeros
        K[:, dep] = B
    return BaseParameters(keep, K, parameter_names(robot))
