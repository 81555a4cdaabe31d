"""Identification of a known UR5 and a known Puma 560 along optimised excitation trajectories
(issue 28).

The truths: the UR5 (example-robot-data's URDF) with its links changed as
``examples/puma_identify.py`` changes the Puma's (masses x1.1, centres of mass moved by
(10, -5, 8) mm, inertias about the centre of mass x1.2 plus the smallest isotropic term that keeps
each a rigid body, plus 1e-4 kg m^2) and drives with viscous friction, asymmetric Coulomb friction
and rotor inertia, the prior being the UR5 with uniform drives; and the Puma 560 of
``examples/puma_identify_truth.toml`` (written by ``examples/puma_identify.py``: the links changed
the same way, viscous friction x1.3, Coulomb friction x1.2 moving up and x0.8 moving down, rotor
inertia x0.9), the prior being the built-in ``puma560``. The motion, per robot:
``mrnea.excitation`` of the prior (small settings, fixed seed), its closed form commanded to the
truth and simulated by
``mrnea.simulate`` at a 1 ms cycle for two periods, logged every 10th cycle (100 Hz) with
positions quantised to 1e-5 rad and Gaussian noise of 0.5 % of each joint's largest effort.

Independent checks:

* the excitation's condition number, recomputed here as numpy's ``cond`` of the stack of
  Pinocchio's ``computeJointTorqueRegressor`` (drive columns written out, base columns chosen by
  mrnea's base parameters), equals the reported one and is below a third of the median of random
  Fourier series drawn here (the same closed form, at rest at t = 0, scaled about their centre
  into the same position, velocity and acceleration limits) scored the same way;
* the least squares base parameters and friction lie within 3 standard errors of the truth's
  base parameters ``K theta_true``;
* the identified robot, through Pinocchio's ``rnea`` plus the drive law written out, predicts the
  truth's efforts (the same) on a different trajectory within the noise;
* every identified link is a rigid body (mass > 0, inertia about the centre of mass positive
  definite with the triangle inequality). The built-in Puma's link 1 (the prior's, and so the
  truth's) has mass 0, not a rigid body: the check is on the identified robot only.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from conftest import PinChain, erd_path, pinocchio_base_condition, sines_trajectory, to_pinocchio

import mrnea
from mrnea.identify import Log, actuator_parameters, identify, inertial_parameters
from mrnea.identify.excite import excitation
from mrnea.model import Robot

F, L, DT = 0.1, 3, 0.01  # [Hz], harmonics, [s] the excitation program's cycle
V, A = 2.0, 10.0  # [rad/s], [rad/s^2] the excitation's limits
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PUMA_TRUTH = EXAMPLES / "puma_identify_truth.toml"
# the example's set-up: the truth's links, the simulation's cycle and what its log keeps
_spec = importlib.util.spec_from_file_location("puma_identify", EXAMPLES / "puma_identify.py")
EXAMPLE = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(EXAMPLE)


def _ur5_prior() -> Robot:
    return mrnea.load_urdf(erd_path("ur_description/urdf/ur5_robot.urdf")).with_actuators(
        gear_ratio=100.0, rotor_inertia=4e-5, viscous_friction=2.0, coulomb_friction=3.0)


def _ur5_truth(prior: Robot) -> Robot:
    return prior._replace(links=EXAMPLE.changed_links(prior), name="ur5_truth").with_actuators(
        rotor_inertia=[5e-5, 5e-5, 4e-5, 2e-5, 2e-5, 2e-5],
        viscous_friction=[4.0, 4.0, 3.0, 1.0, 1.0, 1.0],
        coulomb_friction=[(5.0, 4.0), (6.0, 4.5), (3.0, 3.5), (1.0, 0.7), (1.0, 1.2),
                          (0.8, 0.6)])


def _closed_form(c, a, b, t):
    """q, qd, qdd (K, n) of q_j = c_j + sum_l a_jl sin(w l t) + b_jl cos(w l t), w = 2 pi F."""
    w = 2 * np.pi * F * np.arange(1, a.shape[1] + 1)
    s, co = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))
    return (c + s @ a.T + co @ b.T, (co * w) @ a.T - (s * w) @ b.T,
            -(s * w ** 2) @ a.T - (co * w ** 2) @ b.T)


def _drive_law(r: Robot, qd, qdd) -> np.ndarray:
    """G^2 J_m qdd + F_v qd + F+ [qd > 0] - F- [qd < 0], (K, n) [N m]."""
    c = np.asarray(r.coulomb_friction)
    return (r.gear_ratio ** 2 * r.rotor_inertia * qdd + r.viscous_friction * qd
            + np.where(qd > 0, c[:, 0], 0.0) - np.where(qd < 0, c[:, 1], 0.0))


def _pinocchio_condition(robot: Robot, q, qd, qdd) -> float:
    return pinocchio_base_condition(PinChain(robot, to_pinocchio(robot)), robot, q, qd, qdd)


def _random_series(robot: Robot, rng: np.random.Generator):
    """c, a, b of a random series at rest at t = 0 (c uniform over the middle half of each range,
    harmonic l's amplitudes normal with standard deviation 1/l, harmonic 1 from the others),
    scaled about c by the largest s <= 1 keeping the limits on a fine grid of one period."""
    n = robot.n
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    c = lo + (hi - lo) * rng.uniform(0.25, 0.75, n)
    ell = np.arange(1, L + 1)
    a, b = rng.normal(size=(n, L)) / ell, rng.normal(size=(n, L)) / ell
    a[:, 0] = -(ell[1:] * a[:, 1:]).sum(axis=1)
    b[:, 0] = -(ell[1:] ** 2 * b[:, 1:]).sum(axis=1)
    t = np.linspace(0.0, 1 / F, 5001)
    osc, qd, qdd = _closed_form(np.zeros(n), a, b, t)
    s = min(1.0, V / np.abs(qd).max(), A / np.abs(qdd).max(),
            *(((hi - c) / np.maximum(osc.max(axis=0), 1e-300)).tolist()),
            *(((c - lo) / np.maximum(-osc.min(axis=0), 1e-300)).tolist()))
    return c, s * a, s * b


def _robots(name: str) -> tuple[Robot, Robot]:
    """prior, truth of ``name`` (module docstring)."""
    if name == "ur5":
        prior = _ur5_prior()
        return prior, _ur5_truth(prior)
    return mrnea.robots.puma560(), mrnea.io.load_robot_spec(str(PUMA_TRUTH))


def _case(name: str):
    """prior, truth, the excitation, the noise level per joint [N m], the identification."""
    prior, truth = _robots(name)
    exc = excitation(prior, base_frequency=F, harmonics=L, dt=DT, velocity_limit=V,
                     acceleration_limit=A, candidates=8, starts=1, maxiter=30, seed=5)
    t = np.arange(round(2 / (F * EXAMPLE.CYCLE)) + 1) * EXAMPLE.CYCLE  # two periods, 1 ms
    q_cmd = _closed_form(exc.c, exc.a, exc.b, t)[0]
    sim = mrnea.simulate(truth, q_cmd, EXAMPLE.CYCLE, reactions=False)
    assert sim.achievable, sim.verdict()
    tl, q, tau, noise = EXAMPLE.logged(sim, np.random.default_rng(28))
    return prior, truth, exc, noise, identify(prior, Log(tl, q, tau))


@pytest.fixture(scope="module",
                params=["ur5", pytest.param("puma560", marks=pytest.mark.slow)])  # ~70 s
def case(request):
    return _case(request.param)


def test_excitation_condition_far_below_random_series(case) -> None:
    prior, _, exc, _, _ = case
    t = np.arange(round(1 / (F * DT))) * DT  # one period's cycles
    ours = _pinocchio_condition(prior, *_closed_form(exc.c, exc.a, exc.b, t))
    assert abs(exc.condition - ours) <= 1e-9 * ours
    rng = np.random.default_rng(2028)
    random = [_pinocchio_condition(prior, *_closed_form(*_random_series(prior, rng), t))
              for _ in range(5)]
    assert ours < np.median(random) / 3, (ours, random)


def test_base_parameters_and_friction_within_three_standard_errors(case) -> None:
    prior, truth, _, noise, res = case
    theta = np.concatenate([inertial_parameters(truth), actuator_parameters(truth)])
    beta_true = res.base.K @ theta
    z = (res.beta - beta_true) / res.beta_std
    assert np.all(np.abs(z) <= 3.0), dict(zip(res.base.base_names(), np.round(z, 2), strict=True))
    assert np.all(np.abs(res.sigma / noise - 1) < 0.15), (res.sigma, noise)
    # far from the prior: the log moved the estimate, by many standard errors somewhere
    prior_theta = np.concatenate([inertial_parameters(prior), actuator_parameters(prior)])
    assert np.max(np.abs(res.base.K @ prior_theta - res.beta) / res.beta_std) > 10


def test_predicts_the_truth_through_pinocchio_and_is_consistent(case) -> None:
    _, truth, _, noise, res = case
    _, q, qd, qdd = sines_trajectory(truth)

    def model(r: Robot) -> np.ndarray:
        pin = PinChain(r, to_pinocchio(r))
        rigid = np.array([pin.rnea(*x) for x in zip(q, qd, qdd, strict=True)])
        return rigid + _drive_law(r, qd, qdd)

    moving = np.abs(qd) > 0.05
    err = np.where(moving, model(res.robot) - model(truth), 0)
    rms = np.sqrt((err ** 2).sum(axis=0) / moving.sum(axis=0))
    assert np.all(rms < noise), (rms, noise)
    for lk in res.robot.links:
        e = np.linalg.eigvalsh(np.asarray(lk.inertia))
        assert lk.mass > 0 and e[0] > 0 and e[0] + e[1] >= e[2] * (1 - 1e-12), lk
