"""Properties of the public dynamics API on random chains (hypothesis, derandomized: conftest).

* forward dynamics inverts inverse dynamics, for all four methods;
* mRNEA, Walker-Orin and CRBA give the same H (and mRNEA and Walker-Orin the same bias);
  H is symmetric positive definite;
* a batch call equals the loop of single calls;
* the kernels agree with tests/naive.py, a slow NumPy reference sharing no code with them
  (spatial Newton-Euler; H by its columns and, independently, by centre-of-mass Jacobians);
* the caller's arrays are never written (read-only inputs work and are unchanged);
* the paper's Section IV numerical example in spirit, on the built-in SDT.

Tolerances (``conftest.rel_err``: max abs deviation / max(1, max |reference|)): 1e-9 against
the naive reference, 1e-10 between our own algorithms.
"""

from __future__ import annotations

import naive
import numpy as np
import pytest
from conftest import random_chain, random_states, rel_err
from hypothesis import given, settings
from hypothesis import strategies as st

import mrnea
from mrnea import compiled
from mrnea.kernels.crba import crba
from mrnea.kernels.layout import compile_model

TOL_REF = 1e-9  # against the naive reference
TOL_SELF = 1e-10  # between our algorithms
FD_METHODS = ("mrnea", "walker_orin", "crba", "aba")


class Chain(tuple):
    """(robot, rng) with a repr that reproduces it: ``rng = default_rng(seed)``,
    ``robot = random_chain(rng, n, frac)``, then the states are drawn from ``rng``."""

    def __repr__(self) -> str:
        return "Chain(seed={}, n={}, prismatic_fraction={}) -> {}".format(*self.key, self[0])


@st.composite
def chains(draw, max_n: int = 30):
    """(robot, rng): a random chain of 1..max_n mixed revolute/prismatic joints, and the
    generator (seeded by hypothesis) for its states."""
    n = draw(st.integers(1, max_n))
    frac = draw(st.sampled_from([0.0, 0.3, 0.6, 1.0]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    out = Chain((random_chain(rng, n, frac), rng))
    out.key = (seed, n, frac)
    return out


def fd_tolerance(H: np.ndarray, qdd: np.ndarray) -> float:
    """Absolute tolerance of FD(ID(qdd)) = qdd: solving H x = b amplifies relative errors of b
    (and of H) by up to cond(H), so the round-off of the recovered accelerations scales as
    ``eps * cond(H) * |qdd|``; 1e-13 = ~450 eps leaves room for the O(n) operations that
    accumulate rounding in H, the bias and tau. Never widened to hide a failure."""
    return 1e-13 * np.linalg.cond(H) * max(1.0, float(np.max(np.abs(qdd))))


# --- FD(ID(qdd)) = qdd ---------------------------------------------------------------------------
@settings(max_examples=60)
@given(chains(), st.booleans())
def test_forward_dynamics_inverts_inverse_dynamics(chain, with_fext: bool) -> None:
    robot, rng = chain
    s = random_states(rng, robot)
    fe, pe = (s["f_ext"], s["f_ext_point"]) if with_fext else (None, None)
    tau = mrnea.inverse_dynamics(robot, s["q"], s["qd"], s["qdd"], fe, pe)
    H, _ = mrnea.mass_matrix_and_bias(robot, s["q"], s["qd"])
    tol = fd_tolerance(H, s["qdd"])
    for method in FD_METHODS:
        qdd = mrnea.forward_dynamics(robot, s["q"], s["qd"], tau, fe, pe, method=method)
        err = float(np.max(np.abs(qdd - s["qdd"])))
        assert err <= tol, f"{method}: |FD(ID(qdd)) - qdd| = {err:.3g} > {tol:.3g}"


# --- H: three algorithms, symmetric positive definite --------------------------------------------
@settings(max_examples=60)
@given(chains(), st.booleans())
def test_mass_matrix_algorithms_agree(chain, with_fext: bool) -> None:
    robot, rng = chain
    s = random_states(rng, robot)
    fe, pe = (s["f_ext"], s["f_ext_point"]) if with_fext else (None, None)
    H_m, u_m = mrnea.mass_matrix_and_bias(robot, s["q"], s["qd"], fe, pe, method="mrnea")
    H_w, u_w = mrnea.mass_matrix_and_bias(robot, s["q"], s["qd"], fe, pe, method="walker_orin")
    H_c = np.empty((robot.n, robot.n))
    crba(compile_model(robot), s["q"], H_c)
    assert rel_err(H_m, H_w) <= TOL_SELF
    assert rel_err(H_m, H_c) <= TOL_SELF
    assert rel_err(u_m, u_w) <= TOL_SELF
    # the bias is ID at zero acceleration; H qdd + u' is ID
    tau0 = mrnea.inverse_dynamics(robot, s["q"], s["qd"], np.zeros(robot.n), fe, pe)
    assert rel_err(u_m, tau0) <= TOL_SELF
    tau = mrnea.inverse_dynamics(robot, s["q"], s["qd"], s["qdd"], fe, pe)
    assert rel_err(H_m @ s["qdd"] + u_m, tau) <= TOL_SELF
    for H in (H_m, H_w, H_c):
        assert rel_err(H, H.T) <= TOL_SELF
        assert np.linalg.eigvalsh(0.5 * (H + H.T))[0] > 0.0
        np.linalg.cholesky(H)  # raises if not positive definite


# --- batch = loop of single calls ----------------------------------------------------------------
@settings(max_examples=25)
@given(chains(max_n=12), st.integers(1, 6))
def test_batch_equals_loop(chain, B: int) -> None:
    """Batch and single calls run the same compiled code: the results are identical, bit for
    bit. Also with broadcasting (a single f_ext / f_ext_point for the whole batch)."""
    robot, rng = chain
    s = random_states(rng, robot, B)
    q, qd, qdd, tau, fe, pe = (s[k] for k in ("q", "qd", "qdd", "tau", "f_ext", "f_ext_point"))
    for fe_, pe_ in ((fe, pe), (fe[0], pe[0]), (None, None)):
        def one(b, fe_=fe_, pe_=pe_):
            if fe_ is None:
                return None, None
            return (fe_[b], pe_[b]) if fe_.ndim == 2 else (fe_, pe_)

        batch = mrnea.inverse_dynamics(robot, q, qd, qdd, fe_, pe_)
        for b in range(B):
            np.testing.assert_array_equal(
                batch[b], mrnea.inverse_dynamics(robot, q[b], qd[b], qdd[b], *one(b)))
        batch = mrnea.joint_reactions(robot, q, qd, qdd, fe_, pe_)
        for b in range(B):
            np.testing.assert_array_equal(
                batch[b], mrnea.joint_reactions(robot, q[b], qd[b], qdd[b], *one(b)))
        for method in ("mrnea", "walker_orin"):
            H, u = mrnea.mass_matrix_and_bias(robot, q, qd, fe_, pe_, method=method)
            for b in range(B):
                H1, u1 = mrnea.mass_matrix_and_bias(robot, q[b], qd[b], *one(b), method=method)
                np.testing.assert_array_equal(H[b], H1)
                np.testing.assert_array_equal(u[b], u1)
        for method in FD_METHODS:
            batch = mrnea.forward_dynamics(robot, q, qd, tau, fe_, pe_, method=method)
            for b in range(B):
                np.testing.assert_array_equal(
                    batch[b],
                    mrnea.forward_dynamics(robot, q[b], qd[b], tau[b], *one(b), method=method))


# --- against the naive reference -----------------------------------------------------------------
@settings(max_examples=40)
@given(chains(), st.booleans())
def test_against_naive_reference(chain, with_fext: bool) -> None:
    robot, rng = chain
    s = random_states(rng, robot)
    q, qd, qdd = s["q"], s["qd"], s["qdd"]
    fe, pe = (s["f_ext"], s["f_ext_point"]) if with_fext else (None, None)

    # the two naive mass matrices (Newton-Euler columns, Jacobians) agree with each other
    H_cols = naive.mass_matrix_columns(robot, q)
    H_jac = naive.mass_matrix_jacobian(robot, q)
    assert rel_err(H_cols, H_jac) <= 1e-12

    tau = mrnea.inverse_dynamics(robot, q, qd, qdd, fe, pe)
    assert rel_err(tau, naive.inverse_dynamics(robot, q, qd, qdd, fe, pe)) <= TOL_REF
    for method in ("mrnea", "walker_orin"):
        H, u = mrnea.mass_matrix_and_bias(robot, q, qd, fe, pe, method=method)
        assert rel_err(H, H_cols) <= TOL_REF, method
        assert rel_err(H, H_jac) <= TOL_REF, method
        assert rel_err(u, naive.bias(robot, q, qd, fe, pe)) <= TOL_REF, method
        # at rest the bias is gravity + J^T f_ext, by virtual work (no Newton-Euler)
        _, u0 = mrnea.mass_matrix_and_bias(robot, q, np.zeros(robot.n), fe, pe, method=method)
        assert rel_err(u0, naive.static_bias_jacobian(robot, q, fe, pe)) <= TOL_REF, method


@settings(max_examples=40)
@given(chains(), st.booleans())
def test_joint_reactions_against_naive_reference(chain, with_fext: bool) -> None:
    """Reactions in the joint frame (before the joint's motion), moment about its origin."""
    robot, rng = chain
    s = random_states(rng, robot)
    fe, pe = (s["f_ext"], s["f_ext_point"]) if with_fext else (None, None)
    args = (robot, s["q"], s["qd"], s["qdd"], fe, pe)
    assert rel_err(mrnea.joint_reactions(*args), naive.joint_reactions(*args)) <= TOL_REF


@pytest.mark.parametrize("n", [10, 20, 30])
def test_identical_links_chain_against_naive_reference(n: int) -> None:
    """A deterministic chain of n identical links (origin rpy (0.3, 0.2, 0.1), axis (1, 2, 3)):
    every pose is composed from the previous one, so any loss of orthogonality of the link
    rotations compounds along the chain. ID and H must stay accurate for n up to 30."""
    joints = [mrnea.Joint(f"j{i}", "revolute", "base" if i == 0 else f"l{i - 1}", f"l{i}",
                          origin=mrnea.transform((0.1, 0.0, 0.0), (0.3, 0.2, 0.1)),
                          axis=(1.0, 2.0, 3.0)) for i in range(n)]
    links = [mrnea.Link(f"l{i}", mass=1.0, com=(0.05, 0.0, 0.0), inertia=0.01 * np.eye(3))
             for i in range(n)]
    robot = mrnea.Robot(joints, links)
    q, qd, qdd = np.full(n, 2.0), np.full(n, 0.5), np.full(n, -1.0)
    assert rel_err(mrnea.inverse_dynamics(robot, q, qd, qdd),
                   naive.inverse_dynamics(robot, q, qd, qdd)) <= TOL_REF
    H, _ = mrnea.mass_matrix_and_bias(robot, q, qd)
    assert rel_err(H, naive.mass_matrix_jacobian(robot, q)) <= TOL_REF


def test_naive_reference_textbook_cases() -> None:
    """tests/naive.py itself on cases solvable by hand: a point mass on a horizontal revolute
    arm of length l (tau = m l^2 qdd + m g l cos q), and a vertical slider (f = m (qdd + g))."""
    m, l, g = 2.0, 0.7, 9.81
    arm = mrnea.Robot([mrnea.Joint("j", "revolute", "base", "l", axis=(0, -1, 0))],
                      [mrnea.Link("l", mass=m, com=(l, 0, 0))])
    for qv, qdv, qddv in [(0.0, 0.0, 0.0), (0.3, 1.2, -0.4), (2.0, -3.0, 5.0)]:
        expected = m * l * l * qddv + m * g * l * np.cos(qv)
        assert naive.inverse_dynamics(arm, [qv], [qdv], [qddv])[0] == pytest.approx(expected)
        assert naive.mass_matrix_jacobian(arm, [qv])[0, 0] == pytest.approx(m * l * l)
    slider = mrnea.Robot([mrnea.Joint("j", "prismatic", "base", "l", axis=(0, 0, 1))],
                         [mrnea.Link("l", mass=m, inertia=np.eye(3))])
    assert naive.inverse_dynamics(slider, [0.5], [1.0], [2.0])[0] == pytest.approx(m * (2 + g))
    # the tip pushes down on the environment with 10 N, which pushes back up: the slider's
    # effort is 10 N less (tau gains J^T f_ext = -10)
    assert naive.inverse_dynamics(slider, [0.5], [1.0], [2.0], [0, 0, -10, 0, 0, 0])[0] == (
        pytest.approx(m * (2 + g) - 10))


# --- inputs are never modified --------------------------------------------------------------------
def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


@settings(max_examples=10)
@given(chains(max_n=8), st.sampled_from([None, 3]))
def test_inputs_are_not_modified(chain, B) -> None:
    robot, rng = chain
    s = {k: _readonly(v) for k, v in random_states(rng, robot, B).items()}
    copies = {k: v.copy() for k, v in s.items()}
    q, qd, qdd, tau, fe, pe = (s[k] for k in ("q", "qd", "qdd", "tau", "f_ext", "f_ext_point"))
    mrnea.inverse_dynamics(robot, q, qd, qdd, fe, pe)
    mrnea.joint_reactions(robot, q, qd, qdd, fe, pe)
    for method in ("mrnea", "walker_orin"):
        mrnea.mass_matrix_and_bias(robot, q, qd, fe, pe, method=method)
    for method in FD_METHODS:
        mrnea.forward_dynamics(robot, q, qd, tau, fe, pe, method=method)
    for k, v in s.items():
        np.testing.assert_array_equal(v, copies[k], err_msg=k)
    # the robot's compiled arrays are read-only too, and unchanged
    m, _, _, act = compiled.of(robot)
    assert not m.flags.writeable and not act.flags.writeable
    np.testing.assert_array_equal(m, compile_model(robot))


# --- the paper's Section IV example in spirit: the SDT along a smooth trajectory ------------------
def _sdt() -> mrnea.Robot:
    sdt = getattr(getattr(mrnea, "robots", None), "sdt", None)
    if sdt is None:
        pytest.skip("mrnea.robots.sdt() is not available")
    return sdt()


def test_sdt_trajectory_rnea_equals_mrnea_and_fd_recovers_accelerations() -> None:
    """Paper Sec. IV: along a smooth trajectory (q, qd, qdd)(t_k) of the 4-DoF SDT, the RNEA
    torques equal H qdd + u' from one mRNEA pass (Fig. 3a), and solving Eq. 34 with them gives
    back the input accelerations (Fig. 3b). Checked for every sample and every FD method."""
    robot = _sdt()
    n = robot.n
    t = np.linspace(0.0, 10.0, 501)[:, None]
    k = np.arange(1, n + 1)
    amp, w, phase = 0.8 / k, 0.6 * k, 0.4 * k
    q = amp * np.sin(w * t + phase)
    qd = amp * w * np.cos(w * t + phase)
    qdd = -amp * w * w * np.sin(w * t + phase)
    if robot.is_prismatic.any():  # keep prismatic joints small
        q[:, robot.is_prismatic] *= 0.1
        qd[:, robot.is_prismatic] *= 0.1
        qdd[:, robot.is_prismatic] *= 0.1

    tau = mrnea.inverse_dynamics(robot, q, qd, qdd)
    H, u = mrnea.mass_matrix_and_bias(robot, q, qd)
    assert rel_err(np.einsum("bij,bj->bi", H, qdd) + u, tau) <= TOL_SELF
    for b in range(0, len(t), 50):  # and the reference agrees
        assert rel_err(tau[b], naive.inverse_dynamics(robot, q[b], qd[b], qdd[b])) <= TOL_REF
        assert rel_err(H[b], naive.mass_matrix_jacobian(robot, q[b])) <= TOL_REF
    tol = max(fd_tolerance(H[b], qdd[b]) for b in range(len(t)))
    for method in FD_METHODS:
        rec = mrnea.forward_dynamics(robot, q, qd, tau, method=method)
        err = float(np.max(np.abs(rec - qdd)))
        assert err <= tol, f"{method}: {err:.3g} > {tol:.3g}"
