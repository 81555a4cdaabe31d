"""Physical laws the dynamics must obey, and ill-conditioned but valid models.

Conservation and dissipation are checked on trajectories integrated here with a classical
fourth-order Runge-Kutta scheme (:func:`rk4`, one ``mrnea.forward_dynamics`` call per stage),
so every number comes from the public API plus textbook mechanics:

* kinetic energy ``K = 1/2 qd^T H(q) qd`` (H from ``mrnea.mass_matrix_and_bias``);
* potential energy ``P = -sum_i m_i g . c_i`` with the centres of mass ``c_i`` from forward
  kinematics composed here with NumPy (``T_i = T_{i-1} origin_i motion_i(q_i)``), independent of
  the kernels.

Forward-dynamics agreement on ill-conditioned models uses the forward-error bound of a
backward-stable linear solve (:func:`fd_tolerance`): with H and u' known to a few ulps,
``|dqdd| <~ c eps cond(H) (|qdd| + (|tau| + |u'|) / |H|)``. ``1e-14`` is ``c eps`` with
``c ~ 45``, room for the O(n) operations each recursion adds per entry.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from conftest import random_chain, random_inertia

import mrnea
from mrnea.achievable import achievable_accelerations
from mrnea.actuators import actuator_mass_matrix_and_bias
from mrnea.errors import ModelWarning, SingularMassMatrixError
from mrnea.model import Joint, Link, Robot
from mrnea.rigid import transform
from mrnea.simulate import simulate

FD_METHODS = ("mrnea", "walker_orin", "crba", "aba")
H_STEP = 1e-3  # [s] integration step
T_END = 10.0  # [s] integration time


# --- helpers --------------------------------------------------------------------------------------
def rk4(robot: Robot, q0, qd0, h: float, steps: int, damping=None):
    """Classical RK4 for ``qdd = FD(q, qd, tau)``, ``tau = -damping * qd`` (or 0).

    Returns (Q, QD), each (steps + 1, n), the states at t = 0, h, 2h, ...
    """
    n = robot.n
    fd = mrnea.forward_dynamics
    zero = np.zeros(n)

    def acc(q, qd):
        return fd(robot, q, qd, zero if damping is None else -damping * qd)

    Q = np.empty((steps + 1, n))
    QD = np.empty((steps + 1, n))
    q, qd = np.array(q0, dtype=float), np.array(qd0, dtype=float)
    Q[0], QD[0] = q, qd
    for k in range(steps):
        a1 = acc(q, qd)
        v2 = qd + 0.5 * h * a1
        a2 = acc(q + 0.5 * h * qd, v2)
        v3 = qd + 0.5 * h * a2
        a3 = acc(q + 0.5 * h * v2, v3)
        v4 = qd + h * a3
        a4 = acc(q + h * v3, v4)
        q = q + h / 6.0 * (qd + 2.0 * v2 + 2.0 * v3 + v4)
        qd = qd + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        Q[k + 1], QD[k + 1] = q, qd
    return Q, QD


def _rotation(axis, angle: float) -> np.ndarray:
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def centres_of_mass(robot: Robot, q) -> np.ndarray:
    """(n, 3) centres of mass in the base frame: T_i = T_{i-1} @ origin_i @ motion_i(q_i)."""
    T = np.eye(4)
    out = np.empty((robot.n, 3))
    for i, (j, lk, qi) in enumerate(zip(robot.joints, robot.links, q, strict=True)):
        M = np.eye(4)
        if j.is_prismatic:
            M[:3, 3] = qi * np.asarray(j.axis)
        else:
            M[:3, :3] = _rotation(np.asarray(j.axis), qi)
        T = T @ np.asarray(j.origin) @ M
        out[i] = T[:3, :3] @ np.asarray(lk.com) + T[:3, 3]
    return out


def energies(robot: Robot, Q, QD) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic ``1/2 qd^T H qd`` and potential ``-sum m_i g . c_i`` energy [J] per state."""
    H, _ = mrnea.mass_matrix_and_bias(robot, Q, QD)
    K = 0.5 * np.einsum("ki,kij,kj->k", QD, H, QD)
    g, m = np.asarray(robot.gravity), robot.masses
    P = np.array([-(m * (centres_of_mass(robot, q) @ g)).sum() for q in Q])
    return K, P


def rigid(robot: Robot) -> Robot:
    """The robot without its drives: no rotor, no friction (forward_dynamics ignores them
    anyway; this makes the test's model explicit)."""
    return robot.with_actuators(gear_ratio=1.0, rotor_inertia=0.0, viscous_friction=0.0,
                                coulomb_friction=0.0)


def puma() -> Robot:
    return rigid(mrnea.robots.puma560())


def revolute_chain() -> Robot:
    return random_chain(np.random.default_rng(0), 5, prismatic_fraction=0.0)


def start(robot: Robot, seed: int = 7) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.0, 1.0, robot.n), rng.normal(0.0, 1.0, robot.n)


def fd_tolerance(H, u, tau, qdd) -> float:
    """``1e-14 cond(H) (|qdd| + (|tau| + |u'|) / |H|)``: the forward-error bound of solving
    ``H qdd = tau - u'`` when H, u' and the solve are each accurate to a few ulps (module doc)."""
    norm = np.linalg.norm
    scale = norm(qdd, np.inf) + (norm(tau, np.inf) + norm(u, np.inf)) / norm(H, 2)
    return 1e-14 * np.linalg.cond(H) * scale


def assert_fd_methods_agree(robot: Robot, q, qd, tau) -> float:
    """All four FD methods are finite and agree with a LAPACK solve of ``H qdd = tau - u'``
    within :func:`fd_tolerance`. Returns cond(H)."""
    H, u = mrnea.mass_matrix_and_bias(robot, q, qd)
    assert np.isfinite(H).all() and np.isfinite(u).all()
    ref = np.linalg.solve(H, tau - u)
    tol = fd_tolerance(H, u, tau, ref)
    for method in FD_METHODS:
        qdd = mrnea.forward_dynamics(robot, q, qd, tau, method=method)
        assert np.isfinite(qdd).all(), method
        err = np.max(np.abs(qdd - ref))
        assert err <= tol, f"{method}: |dqdd| {err:.3g} > {tol:.3g}, cond {np.linalg.cond(H):.3g}"
    return float(np.linalg.cond(H))


# --- conservation of energy -----------------------------------------------------------------------
@pytest.mark.parametrize("make", [revolute_chain, puma], ids=["random_chain", "puma560"])
def test_passive_chain_conserves_kinetic_energy(make) -> None:
    """Without gravity, friction or efforts, ``dK/dt = qd^T tau = 0`` (the skew symmetry of
    ``dH/dt - 2C``): the kinetic energy of the free motion is constant.

    RK4 over 10 s at 1 ms (40 000 forward-dynamics calls). Tolerance 1e-8 relative: RK4's energy
    error grows like ``T h^4 omega^5``; for these motions (joint rates up to ~10 rad/s) that is
    ~1e-10 (test_energy_error_is_integration_error shows it is truncation error), so 1e-8 leaves
    a factor ~30 and any modelling error (a wrong Coriolis term, say) shows at O(1e-3).
    """
    robot = make().with_gravity((0.0, 0.0, 0.0))
    q0, qd0 = start(robot)
    Q, QD = rk4(robot, q0, qd0, H_STEP, round(T_END / H_STEP))
    K, _ = energies(robot, Q, QD)
    assert np.abs(QD).max() > 1.0  # it really moved
    drift = np.max(np.abs(K - K[0])) / K[0]
    assert drift <= 1e-8, f"kinetic energy drift {drift:.3g}"


def test_energy_is_conserved_under_gravity() -> None:
    """With gravity and nothing else, ``K + P`` is constant (``dP/dt = qd^T g(q)`` is exactly the
    gravity part of the bias). Puma 560 (drives stripped) swinging from rest-ish for 10 s at 1 ms;
    the energy exchanged (K peaks at ~80 J, P varies by ~80 J) is the scale. Tolerance 1e-8 of
    max K: RK4 truncation gives ~3e-9 here (the light wrist links move fastest)."""
    robot = puma()
    q0, qd0 = start(robot)
    Q, QD = rk4(robot, q0, qd0, H_STEP, round(T_END / H_STEP))
    K, P = energies(robot, Q, QD)
    E = K + P
    assert np.ptp(P) > 0.5 * K.max()  # gravity did work
    drift = np.max(np.abs(E - E[0])) / K.max()
    assert drift <= 1e-8, f"total energy drift {drift:.3g} of max K"


@pytest.mark.parametrize("gravity", [(0.0, 0.0, 0.0), (0.0, 0.0, -9.81)], ids=["free", "gravity"])
def test_energy_error_is_integration_error(gravity) -> None:
    """The energy error is RK4's truncation error, not a modelling error: it shrinks ~16x
    (fourth order) when the step is halved. A dynamics inconsistent with the energy (a missing
    Coriolis term, gravity in the wrong frame) would leave an error that does not shrink.
    Random 5-joint revolute chain, 3 s at 4 ms and 2 ms (fast motions: ~50 rad/s under gravity).
    Accept a ratio >= 10."""
    robot = revolute_chain().with_gravity(gravity)
    q0, qd0 = start(robot)
    drift = []
    for h in (4e-3, 2e-3):
        Q, QD = rk4(robot, q0, qd0, h, round(3.0 / h))
        K, P = energies(robot, Q, QD)
        drift.append(np.max(np.abs(K + P - K[0] - P[0])))
    assert drift[1] > 0.0
    assert drift[0] / drift[1] >= 10.0, f"drift {drift[0]:.3g} -> {drift[1]:.3g}"


def test_viscous_friction_dissipates_energy() -> None:
    """With viscous friction ``tau = -F_v qd``, ``dE/dt = -qd^T F_v qd <= 0``: the total energy
    never increases, and what is lost is the friction's work ``int qd^T F_v qd dt``.

    Puma 560 with gravity, F_v = 0.3 diag H(q0) per joint (time constants ~3 s; a damping that
    is stiff against the light wrist would make explicit RK4 unstable at 1 ms). Monotone within
    rounding: a step may not raise E by more than 1e-12 (|K| + |P|), the rounding of evaluating
    E (~10 ulps of its terms). Power balance to 1e-8 relative: Simpson's rule on the 1 ms
    samples and RK4 are both fourth order, ~1e-11 here.
    """
    robot = puma()
    q0, qd0 = start(robot)
    H0, _ = mrnea.mass_matrix_and_bias(robot, q0, qd0)
    Fv = 0.3 * np.diag(H0)
    steps = round(T_END / H_STEP)
    Q, QD = rk4(robot, q0, qd0, H_STEP, steps, damping=Fv)
    K, P = energies(robot, Q, QD)
    E = K + P
    rounding = 1e-12 * (np.abs(K) + np.abs(P)).max()
    assert np.diff(E).max() <= rounding, f"energy rose by {np.diff(E).max():.3g} J"
    power = np.einsum("ki,i,ki->k", QD, Fv, QD)  # friction's dissipated power [W]
    work = H_STEP / 3.0 * (power[0] + power[-1] + 4.0 * power[1:-1:2].sum()
                           + 2.0 * power[2:-1:2].sum())
    assert E[0] - E[-1] > 0.3 * (E[0] - P.min())  # a real loss, not a rounding artefact
    assert abs((E[0] - E[-1]) - work) <= 1e-8 * work, (E[0] - E[-1], work)


# --- ill-conditioned but valid models -------------------------------------------------------------
def test_large_gear_ratio_rotor_dominates() -> None:
    """G = 1e3, J_m = 1e-4 kg m^2 on every Puma joint: the reflected rotor inertia G^2 J_m = 100
    kg m^2 dwarfs the arm's own (0.01-3 kg m^2), so H_a = H + 100 I is nearly diagonal and the
    arm's coupling is a 1e-4..1e-2 perturbation that must not be lost. Checks: H_a - H is exactly
    diag(G^2 J_m); with every joint saturated (limits at half the need) the achievable
    accelerations solve H_a qdd = tau - u'_a within fd_tolerance(H_a) in both modes; the
    rigid-body FD methods (which ignore the rotor) still agree; the three simulator engines
    give the same 200 saturated cycles (cond(H_a) ~ 1: to 1e-12)."""
    robot = mrnea.robots.puma560().with_actuators(gear_ratio=1e3, rotor_inertia=1e-4)
    rng = np.random.default_rng(3)
    q, qd = rng.uniform(-1.0, 1.0, 6), rng.normal(0.0, 1.0, 6)
    Ha, ua = actuator_mass_matrix_and_bias(robot, q, qd)
    H, _ = mrnea.mass_matrix_and_bias(robot, q, qd)
    np.testing.assert_array_equal(Ha - H, np.diag(np.full(6, 100.0)))
    assert np.abs(H).max() < 0.05 * 100.0  # the rotor dominates
    qdd_des = rng.normal(0.0, 5.0, 6)
    limited = robot.with_actuators(effort_limit=0.5 * np.abs(Ha @ qdd_des + ua))
    for mode in ("paper", "hybrid"):
        res = achievable_accelerations(limited, q, qd, qdd_des, mode=mode)
        assert res.saturated.all()
        ref = np.linalg.solve(Ha, res.tau - ua)
        assert np.max(np.abs(res.qdd - ref)) <= fd_tolerance(Ha, ua, res.tau, ref), mode
        coupling = res.qdd - (res.tau - ua) / np.diag(Ha)  # what the off-diagonal terms do
        assert np.abs(coupling).max() > 1e6 * np.max(np.abs(res.qdd - ref))
    assert_fd_methods_agree(robot, q, qd, rng.normal(0.0, 5.0, 6))
    q_cmd = np.linspace(q, q + 1.5, 200)
    runs = [simulate(limited, q_cmd, 0.005, fd=fd) for fd in ("mrnea", "walker_orin", "crba")]
    assert runs[0].saturated[:-1].any()
    for other in runs[1:]:
        np.testing.assert_allclose(other.q, runs[0].q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(other.tau, runs[0].tau, rtol=1e-12, atol=1e-12)


def spanning_chain(seed: int, heavy_base: bool) -> Robot:
    """A random 7-joint revolute chain whose link masses span 1e-3 ... 1e4 kg (log-spaced,
    heaviest at the base or at the tip), each inertia a solid ellipsoid of that mass."""
    rng = np.random.default_rng(seed)
    base = random_chain(rng, 7, prismatic_fraction=0.0)
    masses = np.logspace(4, -3, 7) if heavy_base else np.logspace(-3, 4, 7)
    links = [Link(lk.name, m, lk.com, random_inertia(rng, m))
             for lk, m in zip(base.links, masses, strict=True)]
    return Robot(base.joints, links, name="spanning")


@pytest.mark.parametrize("heavy_base", [True, False], ids=["heavy_base", "heavy_tip"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_masses_spanning_seven_decades(seed: int, heavy_base: bool) -> None:
    """Masses from 1 g to 10 t along one chain: H is ill-conditioned (cond ~1e7 with the light
    links at the tip), the accelerations of the light links are huge (~1e5 rad/s^2). Every FD
    method stays finite and agrees with the LAPACK solve within fd_tolerance (cond-scaled)."""
    robot = spanning_chain(seed, heavy_base)
    rng = np.random.default_rng(seed + 10)
    conds = []
    for _ in range(4):
        q, qd, tau = rng.uniform(-np.pi, np.pi, 7), rng.normal(0, 1, 7), rng.normal(0, 10, 7)
        conds.append(assert_fd_methods_agree(robot, q, qd, tau))
    if heavy_base:
        assert min(conds) > 1e5  # the case is as ill-conditioned as intended


@pytest.mark.parametrize("q5", [0.0, 1e-12, 1e-8, 1e-4])
def test_puma_wrist_singularity(q5: float) -> None:
    """At q5 = 0 the Puma's joint 4 and 6 axes line up (a kinematic singularity of the
    wrist). H stays positive definite (the links' own inertias), so forward dynamics is
    well-posed: finite, and the four methods agree within fd_tolerance. Also with gravity,
    rotor inertia and friction through achievable_accelerations."""
    robot = mrnea.robots.puma560()
    rng = np.random.default_rng(int(1e3 * q5) + 1)
    for _ in range(3):
        q = rng.uniform(-1.0, 1.0, 6)
        q[4] = q5
        assert_fd_methods_agree(robot, q, rng.normal(0.0, 1.0, 6), rng.normal(0.0, 5.0, 6))
        res = achievable_accelerations(robot, q, rng.normal(0.0, 1.0, 6),
                                       rng.normal(0.0, 20.0, 6))
        assert np.isfinite(res.qdd).all() and np.isfinite(res.tau).all()


def point_mass_arm() -> Robot:
    """Joint a turns about z a 1 kg point mass at 0.5 m along link l2's z; joint b tilts it
    about x. H = diag(m l^2 sin^2 q_b, m l^2): singular at q_b = 0, cond = 1 / sin^2 q_b."""
    joints = [Joint("a", "revolute", "base", "l1", axis=(0, 0, 1)),
              Joint("b", "revolute", "l1", "l2", origin=transform((0.0, 0.0, 0.0)),
                    axis=(1, 0, 0))]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)  # l1 is massless by design
        return Robot(joints, [Link("l1"), Link("l2", mass=1.0, com=(0.0, 0.0, 0.5))])


@pytest.mark.parametrize("qb", [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-9, 0.0])
def test_approaching_a_singular_mass_matrix(qb: float) -> None:
    """As the point mass nears joint a's axis, cond(H) = 1/sin^2 q_b grows without bound. Up to
    the pivot threshold (pivot <= 1e-13 max diag H, i.e. cond ~ 1e13) all four methods return
    finite accelerations that agree within fd_tolerance and match the closed form
    ``qdd_a = (tau_a - u'_a) / (m l^2 sin^2 q_b)``; beyond it all four raise
    SingularMassMatrixError naming joint 'a'. No method returns inf or NaN."""
    robot = point_mass_arm()
    q, qd, tau = np.array([0.2, qb]), np.array([0.5, -0.3]), np.array([0.1, 0.2])
    outcomes = {}
    for method in FD_METHODS:
        try:
            outcomes[method] = mrnea.forward_dynamics(robot, q, qd, tau, method=method)
        except SingularMassMatrixError as exc:
            assert "'a'" in str(exc)
            outcomes[method] = None
    if math.sin(qb) ** 2 > 1e-12:  # well inside the threshold: every method solves
        cond = assert_fd_methods_agree(robot, q, qd, tau)
        assert cond == pytest.approx(1.0 / math.sin(qb) ** 2, rel=1e-6)
        H, u = mrnea.mass_matrix_and_bias(robot, q, qd)
        closed = (tau[0] - u[0]) / (0.25 * math.sin(qb) ** 2)
        tol = fd_tolerance(H, u, tau, np.array([closed, 0.0]))
        for qdd in outcomes.values():
            assert abs(qdd[0] - closed) <= tol
    elif math.sin(qb) ** 2 < 1e-14:  # well beyond: every method refuses
        assert all(v is None for v in outcomes.values()), outcomes
    else:  # near the threshold a method may go either way, but never to inf or NaN
        assert all(v is None or np.isfinite(v).all() for v in outcomes.values())
