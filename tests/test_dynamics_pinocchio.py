"""The public dynamics API against Pinocchio (an independent, widely used implementation).

Random chains (revolute and prismatic joints, random origins, axes and inertias) and real arms
from example-robot-data, >= 100 random states each, compared both as one batch call and as a
few single calls. Every comparison: ``rel_err(ours, pinocchio) <= 1e-9`` (``conftest.rel_err``:
max abs deviation / max(1, max |reference|)).

Conventions mapped (conftest.PinChain): our ``f_ext`` is the wrench the last link exerts ON the
environment (base coordinates, at a point of the last link's frame); Pinocchio's ``fext`` is the
force applied TO each body, in its joint's local frame. Continuous joints are (cos, sin) in
Pinocchio's configuration. ``data.f[i]`` is rotated into our joint frame (before the motion).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import (
    PinChain,
    erd_path,
    pin_from_urdf,
    random_chain,
    random_states,
    rel_err,
    to_pinocchio,
)

import mrnea

TOL = 1e-9
B = 100  # random states per robot
N_SINGLE = 4  # of which this many are also checked one call at a time
FD_METHODS = ("mrnea", "walker_orin", "crba", "aba")
HB_METHODS = ("mrnea", "walker_orin")

# (n, prismatic fraction, seed): n = 1 both kinds, then mixed chains
CHAINS = {
    "n1-revolute": (1, 0.0, 11),
    "n1-prismatic": (1, 1.0, 12),
    "n2-mixed": (2, 0.5, 3),
    "n6-revolute": (6, 0.0, 14),
    "n6-mixed": (6, 0.4, 15),
    "n12-mixed": (12, 0.3, 16),
}

URDFS = {  # name: (file, tip)
    "ur5": ("ur_description/urdf/ur5_robot.urdf", None),
    # the fingers are lumped into the hand (frozen at 0); Pinocchio: locked at 0
    "panda": ("panda_description/urdf/panda.urdf", "panda_hand"),
    # continuous joints 1, 4, 6: (cos, sin) in Pinocchio
    "kinova": ("kinova_description/robots/kinova.urdf", None),
    # PR2's right arm: prismatic torso lift + 7 joints (two continuous); the rest of the robot
    # (head, left arm, gripper...) is lumped, Pinocchio locks it at its neutral (q = 0)
    "pr2-right-arm": ("pr2_description/urdf/pr2.urdf", "r_wrist_roll_link"),
}


class Case:
    """A robot, its Pinocchio twin and a batch of random states."""

    def __init__(self, robot: mrnea.Robot, pc: PinChain, seed: int) -> None:
        self.robot, self.pc = robot, pc
        rng = np.random.default_rng(seed)
        self.s = random_states(rng, robot, B)
        if not np.isinf(robot.lower).all() or not np.isinf(robot.upper).all():
            # real arms: stay within the position limits where they exist
            lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
            hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
            self.s["q"] = rng.uniform(lo, hi, size=(B, robot.n))

    def states(self, with_fext: bool, names: tuple[str, ...]):
        """Batched arrays ``names`` plus (f_ext, f_ext_point) or (None, None)."""
        arrays = [self.s[k] for k in names]
        if with_fext:
            return arrays, self.s["f_ext"], self.s["f_ext_point"]
        return arrays, None, None


_CACHE: dict[str, Case] = {}


def get_case(name: str) -> Case:
    if name not in _CACHE:
        if name in CHAINS:
            n, frac, seed = CHAINS[name]
            robot = random_chain(np.random.default_rng(seed), n, frac)
            if "mixed" in name:  # the seed is chosen so: both kinds of joints
                assert 0 < robot.is_prismatic.sum() < n
            _CACHE[name] = Case(robot, PinChain(robot, to_pinocchio(robot)), seed + 100)
        else:
            rel, tip = URDFS[name]
            path = erd_path(rel)
            robot = mrnea.load_urdf(path, tip=tip)
            _CACHE[name] = Case(robot, PinChain(robot, pin_from_urdf(path, robot)), 7)
    return _CACHE[name]


ALL = [*CHAINS, *URDFS]


def _fe(fe, pe, b):
    return (None, None) if fe is None else (fe[b], pe[b])


def check(batch_out, single, reference, what: str) -> float:
    """Compare the batch result, and the first N_SINGLE single calls, with the reference;
    ``single(b)`` and ``reference(b)`` give state b's results."""
    worst = 0.0
    for b in range(B):
        ref = reference(b)
        err = rel_err(batch_out[b], ref)
        assert err <= TOL, f"{what}, batch state {b}: rel err {err:.3g}"
        worst = max(worst, err)
        if b < N_SINGLE:
            err = rel_err(single(b), ref)
            assert err <= TOL, f"{what}, single state {b}: rel err {err:.3g}"
            worst = max(worst, err)
    return worst


# --- tests ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("with_fext", [False, True], ids=["no-fext", "fext"])
@pytest.mark.parametrize("name", ALL)
def test_inverse_dynamics(name: str, with_fext: bool) -> None:
    c = get_case(name)
    (q, qd, qdd), fe, pe = c.states(with_fext, ("q", "qd", "qdd"))
    tau = mrnea.inverse_dynamics(c.robot, q, qd, qdd, fe, pe)
    assert tau.shape == (B, c.robot.n)
    check(tau,
          lambda b: mrnea.inverse_dynamics(c.robot, q[b], qd[b], qdd[b], *_fe(fe, pe, b)),
          lambda b: c.pc.rnea(q[b], qd[b], qdd[b], *_fe(fe, pe, b)),
          f"{name} inverse_dynamics")


@pytest.mark.parametrize("method", HB_METHODS)
@pytest.mark.parametrize("with_fext", [False, True], ids=["no-fext", "fext"])
@pytest.mark.parametrize("name", ALL)
def test_mass_matrix_and_bias(name: str, with_fext: bool, method: str) -> None:
    c = get_case(name)
    (q, qd), fe, pe = c.states(with_fext, ("q", "qd"))
    H, u = mrnea.mass_matrix_and_bias(c.robot, q, qd, fe, pe, method=method)
    assert H.shape == (B, c.robot.n, c.robot.n)
    check(H,
          lambda b: mrnea.mass_matrix_and_bias(c.robot, q[b], qd[b], *_fe(fe, pe, b),
                                               method=method)[0],
          lambda b: c.pc.mass_matrix(q[b]),
          f"{name} H ({method})")
    check(u,
          lambda b: mrnea.mass_matrix_and_bias(c.robot, q[b], qd[b], *_fe(fe, pe, b),
                                               method=method)[1],
          lambda b: c.pc.bias(q[b], qd[b], *_fe(fe, pe, b)),
          f"{name} bias ({method})")


@pytest.mark.parametrize("method", FD_METHODS)
@pytest.mark.parametrize("with_fext", [False, True], ids=["no-fext", "fext"])
@pytest.mark.parametrize("name", ALL)
def test_forward_dynamics(name: str, with_fext: bool, method: str) -> None:
    c = get_case(name)
    (q, qd, tau), fe, pe = c.states(with_fext, ("q", "qd", "tau"))
    qdd = mrnea.forward_dynamics(c.robot, q, qd, tau, fe, pe, method=method)
    assert qdd.shape == (B, c.robot.n)
    check(qdd,
          lambda b: mrnea.forward_dynamics(c.robot, q[b], qd[b], tau[b], *_fe(fe, pe, b),
                                           method=method),
          lambda b: c.pc.aba(q[b], qd[b], tau[b], *_fe(fe, pe, b)),
          f"{name} forward_dynamics ({method})")


@pytest.mark.parametrize("with_fext", [False, True], ids=["no-fext", "fext"])
@pytest.mark.parametrize("name", ALL)
def test_joint_reactions(name: str, with_fext: bool) -> None:
    c = get_case(name)
    (q, qd, qdd), fe, pe = c.states(with_fext, ("q", "qd", "qdd"))
    out = mrnea.joint_reactions(c.robot, q, qd, qdd, fe, pe)
    assert out.shape == (B, c.robot.n, 6)
    check(out,
          lambda b: mrnea.joint_reactions(c.robot, q[b], qd[b], qdd[b], *_fe(fe, pe, b)),
          lambda b: c.pc.reactions(q[b], qd[b], qdd[b], *_fe(fe, pe, b)),
          f"{name} joint_reactions")
    # the component along the axis is the joint effort
    tau = mrnea.inverse_dynamics(c.robot, q, qd, qdd, fe, pe)
    axes = np.array([j.axis for j in c.robot.joints])
    pris = c.robot.is_prismatic
    along = np.where(pris, np.einsum("bij,ij->bi", out[:, :, :3], axes),
                     np.einsum("bij,ij->bi", out[:, :, 3:], axes))
    assert rel_err(along, tau) <= 1e-10


def test_pinocchio_twin_is_faithful() -> None:
    """The reference itself: our Pinocchio twin of a URDF has the same joints, in order, and
    the urdf models' masses agree (lumping of fixed and locked parts)."""
    for name in URDFS:
        c = get_case(name)
        model = c.pc.model
        assert [model.names[i] for i in c.pc.ids] == list(c.robot.joint_names)
        masses = [model.inertias[i].mass for i in c.pc.ids]
        np.testing.assert_allclose(masses, c.robot.masses, rtol=1e-12)
