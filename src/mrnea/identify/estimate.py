"""``mrnea.identify``: base parameters, friction and rotor inertia from a log by weighted least
squares, then the physically consistent parameters nearest to them (docs/identification.md).

1. Rows. The log's samples give ``tau = W_b(q, qd, qdd) beta`` (base parameters,
   :mod:`mrnea.identify.base`), one row per joint and sample. A joint's row is left out where
   its speed is below ``min_speed`` (Coulomb friction is set-valued at rest).
2. Least squares, twice (Gautier and Poignet 2001): ordinary, then weighted by each joint's
   residual variance ``sigma_j^2 = |r_j|^2 / (N_j - r N_j / N)``; the standard errors are the
   square roots of the diagonal of ``(W_b^T S^-1 W_b)^-1``.
3. Physically consistent parameters: the links through the log-Cholesky factors of their
   pseudo-inertias (:mod:`mrnea.identify.consistent`), the drives' ``G^2 J_m, F_v, F+, F-`` as
   squares (so >= 0), fitted by ``scipy.optimize.least_squares`` (Levenberg-Marquardt, at most
   ``MAX_NFEV`` evaluations) to ``|L^T (K theta - beta_hat)|^2`` (L L^T the
   information matrix above: the weighted data misfit) plus ``prior_weight^2 |(theta -
   theta_prior) / s|^2``, the robot's own (URDF) values as the prior with scales ``s``: the mean
   link mass m, m l and m l^2 (l the mean joint offset, at least 0.1 m) for masses, first and
   second moments and the rotor inertia, 1 N m (s/rad) for friction and offset. Directions the
   log cannot see stay where the prior put them. It starts from the prior's links and, for a
   drive parameter that is a base parameter of its own (a row of K on drive columns alone), from
   the least squares estimate: started at a prior a hundred times off, Levenberg-Marquardt
   stalled far from the data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mrnea import validate
from mrnea.errors import ModelError, StateError, listing, quote
from mrnea.identify.base import BaseParameters, base_parameters, full_regressor
from mrnea.identify.consistent import (
    from_log_cholesky,
    is_consistent,
    log_cholesky_jacobian,
    to_log_cholesky,
)
from mrnea.identify.log import CUTOFF_HZ, MIN_SAMPLES, Log, derivatives, sample_rate
from mrnea.identify.regressor import (
    actuator_parameters,
    inertial_parameters,
    with_inertial_parameters,
)
from mrnea.model import Robot
from mrnea.resources import require_memory

MIN_SPEED = 1e-2  # [rad/s | m/s]: a joint's rows below this speed are left out
PRIOR_WEIGHT = 1e-3
MAX_NFEV = 300  # evaluations of the consistent fit (step 3)
#: The largest condition number of the base regressor over the fitted rows (columns scaled to
#: unit norm) :func:`identify` accepts: beyond, a base parameter is not determined by the log
#: (the efforts' noise amplified 1e10 times; a rank-deficient regressor gives inf). A shipped
#: excitation gives 6-10, the shipped Puma log about 2e3.
MAX_CONDITION = 1e10


@dataclass(frozen=True)
class Prediction:
    """Measured and predicted efforts (K, n) [N m | N] at ``time`` (K,) [s]; ``used`` (K, n)
    bool: the rows of the moving joints (faster than ``min_speed``); ``rms`` (n,) [N m | N] of
    their difference, each joint over its used rows (NaN for a joint with none)."""

    time: NDArray[np.float64]
    measured: NDArray[np.float64]
    predicted: NDArray[np.float64]
    rms: NDArray[np.float64]
    used: NDArray[np.bool_]


@dataclass(frozen=True)
class IdentificationResult:
    """What :func:`identify` found.

    robot: the identified, physically consistent Robot (the prior's kinematics and limits, the
    identified links and drives; the offset folded into the Coulomb pair, which is the same
    effort on a moving joint). base: the base parameters; beta, beta_std (r,): their least
    squares estimate and standard errors; beta_consistent (r,): those of ``robot`` (and the
    offsets); theta (15 n,): the consistent full parameters; sigma (n,) [N m | N]: each joint's
    residual standard deviation; condition: the condition number of the base regressor over the
    rows used (columns scaled to unit norm); fit, validation: efforts on the fitted rows and on
    the held-out ones (or the validation log); offset (n,) [N m | N]; options: the options used
    (``cutoff_hz``, ``min_speed``, ``prior_weight``, ``holdout``), ``validation`` (what
    ``validation`` predicts: ``"log"``, ``"holdout"`` or None) and ``consistent`` (per link: a
    rigid body, :func:`mrnea.identify.consistent.is_consistent`).
    """

    robot: Robot
    base: BaseParameters
    beta: NDArray[np.float64]
    beta_std: NDArray[np.float64]
    beta_consistent: NDArray[np.float64]
    theta: NDArray[np.float64]
    sigma: NDArray[np.float64]
    condition: float
    fit: Prediction
    validation: Prediction | None
    offset: NDArray[np.float64]
    options: dict = field(default_factory=dict)


def _states(log: Log, cutoff_hz: float) -> tuple[NDArray, NDArray, NDArray]:
    if log.qd is not None and log.qdd is not None:
        return log.q, log.qd, log.qdd
    q, qd, qdd = derivatives(log.time, log.q, cutoff_hz)
    return q, (qd if log.qd is None else log.qd), (qdd if log.qdd is None else log.qdd)


def base_rows(robot: Robot, base: BaseParameters, log: Log, cutoff_hz: float, min_speed: float
              ) -> tuple[NDArray, NDArray]:
    """(W_b (K, n, r), used (K, n) bool): the base regressor of every sample and the rows used."""
    q, qd, qdd = _states(log, cutoff_hz)
    W = base.reduce(full_regressor(robot, q, qd, qdd))
    return W, np.abs(qd) >= min_speed


def _least_squares(W: NDArray, tau: NDArray, used: NDArray
                   ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """beta, its covariance, sigma (n,), the information matrix: the weighted LS of step 2."""
    r = W.shape[2]
    A, b = W[used], tau[used]
    beta = _solve(A, b)
    N_j = used.sum(axis=0)
    if np.any(N_j < 2):
        j = int(np.argmin(N_j))
        raise StateError(f"log: joint {j + 1} moves faster than min_speed in {N_j[j]} samples; "
                         f"the log cannot identify it")
    rms = np.sqrt((np.where(used, tau, 0.0) ** 2).sum(axis=0) / N_j)
    if not np.all(rms > 0):
        j = int(np.argmin(rms))
        raise StateError(f"log: joint {j + 1}'s effort is 0 in every sample it moves in; the "
                         "log has no efforts to identify it from")
    # each joint's sigma at least eps times its efforts' rms: an exact fit weighs no joint by
    # 1e300 (the weights' squares would overflow)
    floor = np.finfo(float).eps * rms
    dof = N_j * (1.0 - r / used.sum())
    for _ in range(2):  # ordinary, then weighted by each joint's residual variance
        res = np.where(used, tau - W @ beta, 0.0)
        sigma = np.maximum(np.sqrt((res ** 2).sum(axis=0) / np.maximum(dof, 1.0)), floor)
        w = (1.0 / np.broadcast_to(sigma, used.shape))[used]
        beta = _solve(A * w[:, None], b * w)
    res = np.where(used, tau - W @ beta, 0.0)
    sigma = np.maximum(np.sqrt((res ** 2).sum(axis=0) / np.maximum(dof, 1.0)), floor)
    w = (1.0 / np.broadcast_to(sigma, used.shape))[used]
    info = (A * w[:, None] ** 2).T @ A
    return beta, np.linalg.pinv(info), sigma, info


def _solve(A: NDArray, b: NDArray) -> NDArray[np.float64]:
    """The least squares solution of A x = b (QR with column pivoting, LAPACK's gelsy)."""
    import scipy.linalg  # here, not at the top: every command imports this module

    return scipy.linalg.lstsq(A, b, lapack_driver="gelsy", check_finite=False)[0]


def _condition(A: NDArray) -> float:
    """The condition number of A (rows, r) with its columns scaled to unit norm, from its R
    factor (same singular values, a QR instead of an SVD of the tall matrix)."""
    R = np.linalg.qr(A / np.maximum(np.linalg.norm(A, axis=0), 1e-300), mode="r")
    return float(np.linalg.cond(R))


def _scales(robot: Robot) -> NDArray[np.float64]:
    """s (15 n,): the prior's scale of each parameter (module docstring)."""
    masses = robot.masses[robot.masses > 0]
    m = float(masses.mean()) if masses.size else 1.0
    ell = max(float(np.mean([np.linalg.norm(j.origin[:3, 3]) for j in robot.joints])), 0.1)
    link = [m, m * ell, m * ell, m * ell] + [m * ell ** 2] * 6
    drive = [m * ell ** 2, 1.0, 1.0, 1.0, 1.0]
    return np.array(link * robot.n + drive * robot.n)


def _consistent(robot: Robot, base: BaseParameters, beta: NDArray, info: NDArray,
                prior_weight: float) -> NDArray[np.float64]:
    """theta (15 n,) physically consistent (step 3 of the module docstring)."""
    n = robot.n
    prior = np.concatenate([inertial_parameters(robot), actuator_parameters(robot)])
    s = _scales(robot)
    L = np.linalg.cholesky(info + 1e-12 * np.trace(info) / len(info) * np.eye(len(info)))
    floor = 1e-6 * s[4]

    drive = np.tile([True, True, True, True, False], n)  # G^2 J_m, F_v, F+, F- >= 0: squares

    def theta(x: NDArray) -> NDArray:
        links = [from_log_cholesky(x[10 * i:10 * i + 10]) for i in range(n)]
        a = np.where(drive, x[10 * n:] ** 2, x[10 * n:])
        return np.concatenate([*links, a])

    M = np.vstack([L.T @ base.K, np.diag(prior_weight / s)])  # residuals = M theta - target
    target = np.concatenate([L.T @ beta, prior_weight * prior / s])

    def residuals(x: NDArray) -> NDArray:
        return M @ theta(x) - target

    def jacobian(x: NDArray) -> NDArray:
        D = np.diag(np.concatenate([np.zeros(10 * n), np.where(drive, 2 * x[10 * n:], 1.0)]))
        for i in range(n):
            D[10 * i:10 * i + 10, 10 * i:10 * i + 10] = log_cholesky_jacobian(x[10 * i:10 * i + 10])
        return M @ D

    a0 = prior[10 * n:].copy()  # the drives start from the log's estimate where one is theirs
    for k, c in enumerate(base.columns):
        if c >= 10 * n and not np.any(base.K[k, :10 * n]):
            a0[c - 10 * n] = beta[k]
    start = np.where(drive, np.sqrt(np.maximum(a0, 1e-2 * s[10 * n:])), a0)
    x0 = np.concatenate([*(to_log_cholesky(prior[10 * i:10 * i + 10], floor) for i in range(n)),
                         start])
    import scipy.optimize  # here, not at the top: every command imports this module

    sol = scipy.optimize.least_squares(residuals, x0, jac=jacobian, method="lm",
                                       xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=MAX_NFEV)
    return theta(sol.x)


def _robot(prior: Robot, theta: NDArray) -> tuple[Robot, NDArray]:
    """The Robot of consistent parameters theta, and the offsets (n,). A link or drive the
    model refuses (a centre of mass 1e5 m away: the fit of a log that does not determine it)
    is the log's fault, not the prior's: a StateError saying so."""
    n = prior.n
    try:
        return _built(prior, theta, n)
    except ModelError as exc:
        raise StateError(f"log: the fit gives no robot the model takes ({exc}); the log does "
                         "not determine it: record one that excites every joint (`mrnea "
                         "excite`), or check the efforts' units") from None


def _built(prior: Robot, theta: NDArray, n: int) -> tuple[Robot, NDArray]:
    robot = with_inertial_parameters(prior, theta[:10 * n])
    a = theta[10 * n:].reshape(n, 5)
    offset = a[:, 4]
    coulomb = np.maximum(np.column_stack([a[:, 2] + offset, a[:, 3] - offset]), 0.0)
    robot = robot.with_actuators(rotor_inertia=a[:, 0] / prior.gear_ratio ** 2,
                                 viscous_friction=a[:, 1],
                                 coulomb_friction=[tuple(c) for c in coulomb])
    return robot, offset


def _predict(W: NDArray, beta: NDArray, time: NDArray, tau: NDArray, used: NDArray
             ) -> Prediction:
    """The efforts W beta predicted at ``time`` (K,) [s] against the measured ``tau`` (K, n)."""
    pred = W @ beta
    N = used.sum(axis=0)  # a joint that never moves there has no RMS (NaN), not 0
    with np.errstate(invalid="ignore", divide="ignore"):
        rms = np.sqrt(np.where(used, (tau - pred) ** 2, 0.0).sum(axis=0) / N)
    return Prediction(time, tau, pred, rms, used)


def fit_samples(K: int, holdout: float, validation: bool = False) -> int:
    """How many of a log's K samples the fit takes: all of them with a validation log or a
    ``holdout`` of 0, else the first ``round(K (1 - holdout))`` (the rest is held out)."""
    return K if validation or holdout == 0 else round(K * (1 - holdout))


def check_log(robot: Robot, log: Log, *, validation: Log | None = None, holdout: float = 0.2,
              cutoff_hz: float = CUTOFF_HZ, min_speed: float = MIN_SPEED) -> int:
    """What :func:`identify` checks before its work, cheaply (a filter pass, no regressor), so
    that a log that cannot identify ``robot`` is told at once: the arguments; the part fitted
    (with ``holdout``: at least :data:`MIN_SAMPLES` samples left); the filter's cut-off
    ``cutoff_hz`` [Hz] against each log's sample rate; the memory of the regressor; every joint
    moving faster than ``min_speed`` [rad/s | m/s] in at least 2 samples fitted, with an effort
    other than 0 in one of them. Returns the count of samples fitted (:func:`fit_samples`).

    Raises StateError naming the argument, or the log (``log:``, ``validation log:``) and the
    joint.
    """
    validate.require_robot(robot)
    for what, lg in (("log", log), ("validation", validation)):
        if what == "log" or lg is not None:
            if not isinstance(lg, Log) or lg.q.shape[1] != robot.n or lg.tau.shape[1] != robot.n:
                raise StateError(f"{what}: expected a mrnea.identify.Log of {robot.n} joints "
                                 f"({listing(robot.joint_names)})")
    holdout = validate.real(holdout, "holdout")
    if not 0 <= holdout < 1:
        raise StateError(f"holdout: must be in [0, 1), got {holdout}")
    min_speed = validate.real(min_speed, "min_speed")
    if not (math.isfinite(min_speed) and min_speed >= 0):
        raise StateError(f"min_speed: must be a finite number >= 0, got {min_speed}")
    K, n = log.K, robot.n
    K_fit = fit_samples(K, holdout, validation is not None)
    if K_fit < MIN_SAMPLES:
        most = math.floor(1000 * (1 - MIN_SAMPLES / K)) / 1000  # leaves MIN_SAMPLES or more
        raise StateError(f"holdout: {holdout:g} holds out {K - K_fit} of the log's {K} samples, "
                         f"leaving {K_fit} to fit, fewer than the {MIN_SAMPLES} a fit needs: "
                         f"a smaller holdout (at most {most:g} for this log; 0: fit all of it), "
                         "a validation log, or a longer log")
    for what, lg in (("log", log), ("validation log", validation)):
        if lg is not None and (lg.qd is None or lg.qdd is None):
            try:
                sample_rate(lg.time, cutoff_hz)
            except StateError as exc:
                raise StateError(f"{what}: {exc}") from None
    rows = K + (0 if validation is None else validation.K)
    # the full regressor (and its copy in the kernel's reduction), the base regressor, the rows
    # fitted and their weighted copies [bytes], the base parameters at most 15 n (no kernel
    # runs here: measured 3.8 GB for 300 000 Puma samples, estimated 5.2 GB)
    require_memory(8.0 * rows * n * (2 * 15 * n + 2 * 15 * n),
                   f"identifying {n} joints from {rows} samples",
                   "log at a lower rate (the fit needs no more than a few hundred hertz) or "
                   "a shorter log", StateError)
    qd = _states(log, cutoff_hz)[1][:K_fit]
    moving = np.abs(qd) >= min_speed
    N_j = moving.sum(axis=0)
    for j, joint in enumerate(robot.joints):
        unit = joint.unit("qd")
        if N_j[j] < 2:
            raise StateError(f"log: joint {quote(joint.name)} moves faster than min_speed "
                             f"({min_speed:g} {unit}) in {N_j[j]} of the {K_fit} samples fitted; "
                             "the log cannot identify it: record one in which every joint moves "
                             "(`mrnea excite` designs one)")
        if not np.any(log.tau[:K_fit, j][moving[:, j]] != 0):
            raise StateError(f"log: the effort of joint {quote(joint.name)} is 0 in every sample "
                             "it moves in; the log has no efforts to identify it from")
    return K_fit


def identify(robot: Robot, log: Log, *, validation: Log | None = None, holdout: float = 0.2,
             cutoff_hz: float = CUTOFF_HZ, min_speed: float = MIN_SPEED,
             prior_weight: float = PRIOR_WEIGHT, physical: bool = True) -> IdentificationResult:
    """Identify ``robot``'s links and drives from ``log`` (module docstring).

    ``robot``: the kinematics, limits and gear ratios to keep, and the prior (its inertials and
    drives). ``log``: a :class:`mrnea.identify.Log` (joint-side efforts; velocities and
    accelerations by :func:`mrnea.identify.derivatives` at ``cutoff_hz`` [Hz] unless given).
    ``validation``: a second log to predict; without it the last ``holdout`` fraction (0 to
    < 1) of ``log`` is held out. ``min_speed`` [rad/s | m/s]: a joint's rows slower than this
    are left out. ``physical=False`` skips step 3 (``robot`` and ``theta`` are then the prior's).
    """
    prior_weight = validate.real(prior_weight, "prior_weight")  # the arguments before the log
    if not (math.isfinite(prior_weight) and prior_weight >= 0):
        raise StateError(f"prior_weight: must be a finite number >= 0, got {prior_weight}")
    K_fit = check_log(robot, log, validation=validation, holdout=holdout, cutoff_hz=cutoff_hz,
                      min_speed=min_speed)
    holdout, min_speed = float(holdout), float(min_speed)
    base = base_parameters(robot)
    W, used = base_rows(robot, base, log, cutoff_hz, min_speed)
    beta, cov, sigma, info = _least_squares(W[:K_fit], log.tau[:K_fit], used[:K_fit])
    cond = _condition(W[:K_fit][used[:K_fit]])
    if not cond <= MAX_CONDITION:
        raise StateError(f"log: its {K_fit} samples fitted ({int(used[:K_fit].sum())} joint "
                         f"rows) do not determine every base parameter (condition number "
                         f"{cond:.3g} of the base regressor, at most {MAX_CONDITION:g} "
                         "taken): record a longer log, "
                         "or one of `mrnea excite`'s trajectories")
    prior = np.concatenate([inertial_parameters(robot), actuator_parameters(robot)])
    theta = _consistent(robot, base, beta, info, prior_weight) if physical else prior
    ident, offset = _robot(robot, theta) if physical else (robot, np.zeros(robot.n))
    beta_c = base.K @ theta
    if validation is not None:
        Wv, usedv = base_rows(robot, base, validation, cutoff_hz, min_speed)
        val = _predict(Wv, beta_c, validation.time, validation.tau, usedv)
    elif K_fit < log.K:
        val = _predict(W[K_fit:], beta_c, log.time[K_fit:], log.tau[K_fit:], used[K_fit:])
    else:
        val = None
    return IdentificationResult(
        ident, base, beta, np.sqrt(np.diag(cov)), beta_c, theta, sigma, cond,
        _predict(W[:K_fit], beta, log.time[:K_fit], log.tau[:K_fit], used[:K_fit]), val, offset,
        {"cutoff_hz": cutoff_hz, "min_speed": min_speed, "prior_weight": prior_weight,
         "holdout": holdout,
         "validation": "log" if validation is not None else "holdout" if val is not None else None,
         "consistent": [bool(is_consistent(theta[10 * i:10 * i + 10])) for i in range(robot.n)]})
