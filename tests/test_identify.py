"""Identification (mrnea.identify) on logs simulated by mrnea from a known robot.

The truth: the Puma 560 with its links' inertials changed (masses x1.1, centres of mass moved,
inertias x1.2: still rigid bodies) and asymmetric Coulomb friction, viscous friction and rotor
inertia; the UR5 with drives added. The prior is the unchanged robot. A log: a Fourier
trajectory (periodic, at rest at its start), the truth's efforts by mrnea.actuators (the drive
law), Gaussian noise on the efforts, positions quantised to 1e-5 rad, velocities and
accelerations by the zero-phase filter. Checks: the base parameters and friction within 3
standard errors of the truth (K theta_true, the truth's own parameters through the base
projection), the efforts predicted on a different trajectory within the noise of the truth's,
every identified link a rigid body (checked here from its mass, centre of mass and inertia
about it: eigenvalues > 0 and the triangle inequality), and without noise, with exact rates,
the truth to 1e-8.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import erd_path, random_states, rel_err

import mrnea
from mrnea.actuators import actuator_efforts
from mrnea.identify import Log, actuator_parameters, identify, inertial_parameters
from mrnea.identify.base import base_parameters, full_regressor
from mrnea.identify.fourier import coefficients, evaluate
from mrnea.model import Link

RATE = 100.0  # [Hz] of the simulated logs
DURATION = 20.0  # [s]: two periods at 0.1 Hz
QUANTUM = 1e-5  # [rad] encoder resolution


def _changed_links(robot: mrnea.Robot) -> mrnea.Robot:
    links = [Link(lk.name, 1.1 * lk.mass, np.asarray(lk.com) + 0.01, 1.2 * np.asarray(lk.inertia),
                  lk.visuals) for lk in robot.links]
    return robot._replace(links=tuple(links))


def _truth(which: str) -> tuple[mrnea.Robot, mrnea.Robot]:
    """(prior, truth)."""
    if which == "puma":
        prior = mrnea.robots.puma560()
        truth = _changed_links(prior).with_actuators(
            viscous_friction=prior.viscous_friction * 1.3,
            coulomb_friction=[(1.2 * p, 0.8 * m) for p, m in prior.coulomb_friction],
            rotor_inertia=prior.rotor_inertia * 0.9)
    else:
        prior = mrnea.load_urdf(erd_path("ur_description/urdf/ur5_robot.urdf")).with_actuators(
            gear_ratio=100.0, rotor_inertia=4e-5, viscous_friction=2.0,
            coulomb_friction=3.0)
        truth = _changed_links(prior).with_actuators(
            rotor_inertia=[5e-5, 5e-5, 4e-5, 2e-5, 2e-5, 2e-5],
            viscous_friction=[4.0, 4.0, 3.0, 1.0, 1.0, 1.0],
            coulomb_friction=[(5.0, 4.0), (6.0, 4.5), (3.0, 3.5), (1.0, 0.7), (1.0, 1.2),
                              (0.8, 0.6)])
    return prior, truth


def _trajectory(robot: mrnea.Robot, seed: int, amplitude: float = 0.03):
    """A Fourier trajectory (5 harmonics, 0.1 Hz) about the middle of the limits: t, q, qd, qdd."""
    n, L = robot.n, 5
    rng = np.random.default_rng(seed)
    free = rng.normal(0.0, amplitude, size=(n, 1 + 2 * (L - 1)))
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    free[:, 0] = (lo + hi) / 2 + rng.uniform(-0.3, 0.3, n)
    c, a, b = coefficients(free, n, L)
    t = np.arange(0.0, DURATION, 1.0 / RATE)
    return (t, *evaluate(c, a, b, 0.1, t))


def _theta(robot: mrnea.Robot) -> np.ndarray:
    return np.concatenate([inertial_parameters(robot), actuator_parameters(robot)])


def _rigid_body(link: Link) -> bool:
    e = np.linalg.eigvalsh(np.asarray(link.inertia))
    return link.mass > 0 and e[0] > 0 and e[0] + e[1] >= e[2] * (1 - 1e-12)


_RESULTS: dict = {}


def _noisy(which: str):
    if which not in _RESULTS:
        prior, truth = _truth(which)
        rng = np.random.default_rng(28)
        t, q, qd, qdd = _trajectory(prior, 1)
        tau = actuator_efforts(truth, q, qd, qdd)
        noise = 0.005 * np.abs(tau).max(axis=0)
        log = Log(t, np.round(q / QUANTUM) * QUANTUM, tau + rng.normal(size=tau.shape) * noise)
        tv, qv, qdv, qddv = _trajectory(prior, 2)  # a different trajectory, noise-free truth
        check = Log(tv, qv, actuator_efforts(truth, qv, qdv, qddv), qdv, qddv)
        _RESULTS[which] = (prior, truth, noise, identify(prior, log, validation=check))
    return _RESULTS[which]


@pytest.mark.slow
@pytest.mark.parametrize("which", ["puma", "ur5"])
def test_noisy_log_within_three_standard_errors(which: str) -> None:
    prior, truth, noise, res = _noisy(which)
    beta_true = res.base.K @ _theta(truth)
    z = (res.beta - beta_true) / res.beta_std
    assert np.all(np.abs(z) <= 3.0), dict(zip(res.base.base_names(), np.round(z, 2), strict=True))
    assert np.all(np.abs(res.sigma / noise - 1) < 0.1)  # the noise level itself, estimated
    # far from the prior: the log moved the estimate, by many standard errors somewhere
    assert np.max(np.abs(res.base.K @ _theta(prior) - res.beta) / res.beta_std) > 10


@pytest.mark.slow
@pytest.mark.parametrize("which", ["puma", "ur5"])
def test_predicted_efforts_and_physical_consistency(which: str) -> None:
    prior, truth, noise, res = _noisy(which)
    assert np.all(res.validation.rms < noise), (res.validation.rms, noise)
    for lk in res.robot.links:
        assert _rigid_body(lk), lk
    # the identified Robot itself (drive law included) predicts the truth on the other trajectory
    _, q, qd, qdd = _trajectory(prior, 2)
    moving = np.abs(qd) > 0.05
    err = actuator_efforts(res.robot, q, qd, qdd) - actuator_efforts(truth, q, qd, qdd)
    rms = np.sqrt((np.where(moving, err, 0) ** 2).sum(axis=0) / moving.sum(axis=0))
    assert np.all(rms < noise), (rms, noise)


@pytest.mark.slow
@pytest.mark.parametrize("which", ["puma", "ur5"])
def test_noise_free_log_recovers_the_truth(which: str) -> None:
    prior, truth = _truth(which)
    t, q, qd, qdd = _trajectory(prior, 1)
    res = identify(prior, Log(t, q, actuator_efforts(truth, q, qd, qdd), qd, qdd),
                   physical=False)
    beta_true = res.base.K @ _theta(truth)
    assert rel_err(res.beta, beta_true) <= 1e-8
    assert np.all(np.abs(res.beta - beta_true) <= 1e-8 * np.maximum(np.abs(beta_true), 1e-3))


@pytest.mark.parametrize("which", ["puma", "ur5"])
def test_base_parameters_reproduce_the_full_model(which: str) -> None:
    """W theta = W_b (K theta) for any theta, on states the QR never saw; the rank is W's."""
    robot = _truth(which)[0]
    bp = base_parameters(robot)
    s = random_states(np.random.default_rng(5), robot, 300)
    W = full_regressor(robot, s["q"], s["qd"], s["qdd"])
    for th in [_theta(robot), np.random.default_rng(6).normal(size=15 * robot.n)]:
        assert rel_err(bp.reduce(W) @ (bp.K @ th), W @ th) <= 1e-10
    Wf = W.reshape(-1, 15 * robot.n)
    norms = np.linalg.norm(Wf, axis=0)
    Wf = Wf[:, norms > 1e-9 * norms.max()]
    S = np.linalg.svd(Wf / np.linalg.norm(Wf, axis=0), compute_uv=False)
    assert bp.r == np.count_nonzero(S > 1e-8 * S[0])
    # the identified model's efforts: exactly the drive law's (rigid body, rotor, friction)
    tau = W @ _theta(robot)
    assert rel_err(tau, actuator_efforts(robot, s["q"], s["qd"], s["qdd"])) <= 1e-12


def test_bad_logs_are_refused() -> None:
    robot = mrnea.robots.puma560()
    t, q, qd, qdd = _trajectory(robot, 1)
    tau = actuator_efforts(robot, q, qd, qdd)
    with pytest.raises(mrnea.StateError, match="time"):
        Log(t[::-1], q, tau)
    bad = tau.copy()
    bad[7, 2] = np.nan
    with pytest.raises(mrnea.StateError, match="tau is NaN or inf at sample 7"):
        Log(t, q, bad)
    with pytest.raises(mrnea.StateError, match="cutoff"):
        identify(robot, Log(t, q, tau), cutoff_hz=60.0)
    with pytest.raises(mrnea.StateError, match="holdout"):
        identify(robot, Log(t, q, tau), holdout=1.0)


# --- the log file -------------------------------------------------------------------------------
def _write_log(path, robot, rows, currents=False):
    from mrnea.identify.log import log_columns
    lines = [",".join(log_columns(robot, currents))]
    lines += [",".join(repr(float(x)) for x in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")


def test_read_log_reads_back_and_names_the_bad_row(tmp_path):
    """A log written with its documented header reads back exactly (columns in any order);
    currents become tau = G k_t i; a missing column, NaN or a time that does not increase is
    one LogFileError naming the row."""
    from mrnea.errors import LogFileError
    from mrnea.identify import read_log
    robot = mrnea.robots.puma560()
    n, K = robot.n, 40
    rng = np.random.default_rng(3)
    t = np.arange(K) * 0.01
    q, tau = rng.normal(size=(K, n)), rng.normal(size=(K, n))
    rows = np.column_stack([t, q, tau])
    _write_log(tmp_path / "a.csv", robot, rows)
    log = read_log(tmp_path / "a.csv", robot)
    assert np.array_equal(log.time, t) and np.array_equal(log.q, q)
    assert np.array_equal(log.tau, tau) and log.qd is None
    # columns in another order: the reverse
    text = (tmp_path / "a.csv").read_text().splitlines()
    rev = [",".join(line.split(",")[::-1]) for line in text]
    (tmp_path / "r.csv").write_text("\n".join(rev) + "\n")
    assert np.array_equal(read_log(tmp_path / "r.csv", robot).tau, tau)
    # currents [A] with k_t [N m/A, motor side]: tau = G k_t i, by hand
    _write_log(tmp_path / "i.csv", robot, rows, currents=True)
    kt = 0.5
    got = read_log(tmp_path / "i.csv", robot, torque_constant=kt).tau
    assert np.allclose(got, tau * kt * np.asarray(robot.gear_ratio), rtol=1e-15, atol=0)
    # bad files
    (tmp_path / "m.csv").write_text("\n".join(line.rsplit(",", 1)[0] for line in text) + "\n")
    with pytest.raises(LogFileError, match=r"row 1: missing column 'tau_"):
        read_log(tmp_path / "m.csv", robot)
    bad = rows.copy()
    bad[7, 2] = np.nan
    _write_log(tmp_path / "n.csv", robot, bad)
    with pytest.raises(LogFileError, match=r"row 9: column .* is NaN"):
        read_log(tmp_path / "n.csv", robot)
    bad = rows.copy()
    bad[12, 0] = bad[11, 0]
    _write_log(tmp_path / "t.csv", robot, bad)
    with pytest.raises(LogFileError, match=r"row 14: time .* does not increase"):
        read_log(tmp_path / "t.csv", robot)
