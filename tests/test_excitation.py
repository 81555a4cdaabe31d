"""Excitation trajectories (mrnea.identify.excite and ``mrnea excite``).

Independent checks: the Fourier series is evaluated here from its closed form (q, qd, qdd written
out, not mrnea.identify.fourier) on a grid 50 times finer than the program's, for the position,
velocity and acceleration limits and the rest at both ends; the efforts at every cycle by
Pinocchio's RNEA plus the drive law written out; the condition number reported against numpy's
cond of the stack of Pinocchio's ``computeJointTorqueRegressor`` (with the drive columns written
out, the base columns chosen by mrnea's base parameters); the program read back by mrnea's
program reader; the command as a real process.
"""

from __future__ import annotations

import dataclasses
import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import (
    PinChain,
    environment,
    mrnea_cli,
    one_error_line,
    pin_from_urdf,
    pinocchio_base_condition,
    random_chain,
)

import mrnea
from mrnea.identify.excite import excitation
from mrnea.io import load_program

F, L, DT = 0.1, 3, 0.01  # [Hz], harmonics, [s]
V, A, MARGIN = 2.0, 10.0, 0.9  # [rad/s], [rad/s^2], effort margin
SMALL = {"base_frequency": F, "harmonics": L, "dt": DT, "velocity_limit": V,
         "acceleration_limit": A, "effort_margin": MARGIN, "candidates": 8, "maxiter": 30}


@pytest.fixture(scope="module")
def puma():
    return mrnea.robots.puma560()


@pytest.fixture(scope="module")
def optimised(puma):
    return excitation(puma, starts=1, **SMALL)


def _closed_form(exc, t):
    """q, qd, qdd (K, n) of q_j = c_j + sum_l a_jl sin(w l t) + b_jl cos(w l t), w = 2 pi f."""
    w = 2 * np.pi * exc.base_frequency * np.arange(1, exc.a.shape[1] + 1)
    s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))
    q = exc.c + s @ exc.a.T + c @ exc.b.T
    qd = (c * w) @ exc.a.T - (s * w) @ exc.b.T
    qdd = -(s * w ** 2) @ exc.a.T - (c * w ** 2) @ exc.b.T
    return q, qd, qdd


def test_limits_rest_and_rows(optimised, puma) -> None:
    exc = optimised
    period = 1 / F
    t = np.linspace(0.0, period, 50 * round(period / DT) + 1)
    q, qd, qdd = _closed_form(exc, t)
    assert np.all(q >= puma.lower) and np.all(q <= puma.upper)
    assert np.abs(qd).max() <= V and np.abs(qdd).max() <= A
    assert np.abs(qd[[0, -1]]).max() <= 1e-12 and np.abs(qdd[[0, -1]]).max() <= 1e-10
    # the program's rows are the closed form at t = k dt, the last one the first
    assert np.array_equal(exc.t, np.arange(exc.q_cmd.shape[0]) * DT)
    assert np.abs(exc.q_cmd - _closed_form(exc, exc.t)[0]).max() <= 1e-12
    assert np.array_equal(exc.q_cmd[-1], exc.q_cmd[0])


def test_efforts_within_margin_by_pinocchio(optimised, puma, tmp_path) -> None:
    exc = optimised
    pc = PinChain(puma, pin_from_urdf(puma.to_urdf(tmp_path / "puma.urdf"), puma))
    q, qd, qdd = _closed_form(exc, exc.t)
    G2Jm, Fv, Fc = puma.gear_ratio ** 2 * puma.rotor_inertia, puma.viscous_friction, \
        puma.coulomb_friction
    worst = 0.0
    for k in range(len(exc.t)):
        tau = (pc.rnea(q[k], qd[k], qdd[k]) + G2Jm * qdd[k] + Fv * qd[k]
               + np.where(qd[k] > 0, Fc[:, 0], 0) - np.where(qd[k] < 0, Fc[:, 1], 0))
        worst = max(worst, float(np.max(np.abs(tau) / puma.effort_limit)))
    assert worst <= MARGIN * (1 + 1e-9)
    assert exc.achievable, exc.verdict


def test_condition_equals_numpy_cond_of_pinocchio_stack(optimised, puma, tmp_path) -> None:
    exc = optimised
    pc = PinChain(puma, pin_from_urdf(puma.to_urdf(tmp_path / "puma.urdf"), puma))
    t = np.arange(round(1 / (F * DT))) * DT  # one period's cycles
    ref = pinocchio_base_condition(pc, puma, *_closed_form(exc, t))
    assert abs(exc.condition - ref) <= 1e-9 * ref


def test_optimisation_improves_over_its_start(optimised, puma) -> None:
    start = excitation(puma, starts=0, **SMALL)  # the best random candidate, not optimised
    assert start.condition == optimised.condition_start
    assert optimised.condition <= 0.7 * start.condition, (optimised.condition, start.condition)


def test_program_files_read_back(optimised, puma, tmp_path) -> None:
    csv = optimised.save_csv(tmp_path / "exc.csv")
    path = optimised.save_program(tmp_path / "exc.toml", "puma560", csv.name)
    prog = load_program(path)
    assert prog.robot == "puma560" and prog.dt == DT
    assert np.array_equal(prog.q_cmd, optimised.q_cmd)
    with pytest.raises(mrnea.MrneaError, match="exists"):
        optimised.save_csv(csv)


@pytest.mark.parametrize(("kw", "name"), [
    ({"harmonics": 1}, "harmonics"), ({"harmonics": 2.5}, "harmonics"),
    ({"base_frequency": 0.0}, "base_frequency"), ({"base_frequency": float("nan")},
                                                   "base_frequency"),
    ({"duration": 15.0}, "duration"), ({"dt": 0.003}, "dt"), ({"dt": 0.5}, "dt"),
    ({"velocity_limit": -1.0}, "velocity_limit"), ({"velocity_limit": [1.0, 2.0]},
                                                    "velocity_limit"),
    ({"acceleration_limit": float("nan")}, "acceleration_limit"),
    ({"effort_margin": 0.0}, "effort_margin"), ({"effort_margin": 1.5}, "effort_margin"),
    ({"candidates": 2, "starts": 3}, "starts"), ({"seed": -1}, "seed"),
    ({"samples": 2}, "samples")])
def test_bad_arguments(puma, kw, name) -> None:
    args = {**SMALL, **kw}
    with pytest.raises(mrnea.StateError, match=f"^{name}:"):
        excitation(puma, **args)


def test_tree_refused() -> None:
    chain = random_chain(np.random.default_rng(1), 3)
    joints = list(chain.joints)
    joints[2] = dataclasses.replace(joints[2], parent=chain.links[0].name)  # a branch at link 0
    robot = mrnea.Robot(joints, chain.links)
    with pytest.raises(mrnea.ModelError, match="serial"):
        excitation(robot, **SMALL)


@pytest.mark.slow
def test_cli_excite_writes_a_program_mrnea_checks(tmp_path) -> None:
    out = tmp_path / "exc"
    args = ["excite", "puma560", "--out", out, "--harmonics", "2", "--candidates", "3",
            "--starts", "1", "--dt", "0.02", "--velocity-limit", "2", "--acceleration-limit",
            "8", "--quiet"]
    res = mrnea_cli(*args)
    assert res.returncode == 0, res.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["achievable"] and summary["condition"] <= summary["condition_start"]
    assert summary["limits"]["velocity"] == [2.0] * 6
    check = mrnea_cli("check", out / "excitation.toml")
    assert check.returncode == 0 and "ACHIEVABLE" in check.stdout, check.stderr
    one_error_line(mrnea_cli(*args), "excitation.csv", "--force")
    assert mrnea_cli(*args, "--force").returncode == 0


@pytest.mark.parametrize(("extra", "word"), [
    (["--velocity-limit", "1,2"], "--velocity-limit"),  # a count that is not the robot's
    (["--acceleration-limit", "abc"], "--acceleration-limit"),  # not a number
    (["--duration", "15"], "--duration"),  # the library's check, in the option's name
    (["--harmonics", "1"], "--harmonics")])
def test_cli_bad_input(tmp_path, extra, word) -> None:
    res = mrnea_cli("excite", "puma560", "--out", tmp_path / "o", *extra)
    one_error_line(res, word)
    assert not (tmp_path / "o" / "excitation.csv").exists()


def test_gradients_equal_central_differences(puma) -> None:
    """The criterion's analytic gradient and the efforts' Jacobian against central differences
    of the criterion and the efforts themselves (step 1e-6 on the free numbers)."""
    from mrnea.identify.base import base_parameters as bp
    from mrnea.identify.criterion import Problem
    from mrnea.identify.excite import limits_of, random_free

    limits = limits_of(puma, V, A, MARGIN)
    problem = Problem(puma, bp(puma), limits, L, F, 40)
    x = random_free(np.random.default_rng(3), limits, L).ravel() * 0.2
    x[::2 * L - 1] = (puma.lower + puma.upper) / 2
    g, J = problem.gradient(x), problem.efforts_jacobian(x)
    h = 1e-6
    for i in range(0, x.size, 4):
        e = np.zeros_like(x)
        e[i] = h
        fd = (problem.value(x + e) - problem.value(x - e)) / (2 * h)
        assert abs(g[i] - fd) <= 1e-6 * max(1.0, abs(fd)), (i, g[i], fd)
        fd = (problem.efforts(x + e) - problem.efforts(x - e)) / (2 * h)
        assert np.abs(J[:, i] - fd).max() <= 1e-6 * max(1.0, np.abs(fd).max()), i


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_cli_stop_request_ends_soon_and_writes_nothing(tmp_path, sig) -> None:
    out = tmp_path / "o"
    p = subprocess.Popen([sys.executable, "-m", "mrnea", "excite", "puma560", "--out", str(out),
                          "--velocity-limit", "2", "--harmonics", "10", "--quiet"],
                         env=environment(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    deadline = time.monotonic() + 120
    while not out.exists() and time.monotonic() < deadline:  # the run owns its folder
        assert p.poll() is None, p.communicate()
        time.sleep(0.05)
    # into the candidates or the optimisation: with 10 harmonics about 15 s in all on a warm
    # cache (the default 5 take 3 s: a stop 3 s in had found the run finished, exit 0)
    time.sleep(1.0)
    assert p.poll() is None, "the run ended before the stop request"
    sent = time.monotonic()
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert time.monotonic() - sent < 20, "the stop request waited for the end"
    assert not out.exists() or not any(out.iterdir())  # the run's own empty folder goes too


@pytest.mark.slow
def test_cli_robot_named_by_a_program(tmp_path) -> None:
    """ROBOT may be a program file: the excitation program names the program's robot."""
    prog = tmp_path / "p.toml"
    prog.write_text('[program]\nrobot = "puma560"\ndt = 0.01\npayload = "2.0"\n[path]\n'
                    'profile = "quintic"\nwaypoints = [[0, 0, 0, 0, 0, 0], [0.1, 0, 0, 0, 0, 0]]\n'
                    'velocity_limit = 1.0\nacceleration_limit = 2.0\n')
    res = mrnea_cli("excite", prog, "--out", tmp_path / "o", "--harmonics", "2", "--candidates",
                    "2", "--starts", "1", "--dt", "0.02", "--velocity-limit", "2", "--quiet")
    assert res.returncode == 0, res.stderr
    written = load_program(tmp_path / "o" / "excitation.toml")
    assert written.robot == "puma560"
    assert [p.mass for p in written.options.payload] == [2.0]  # a tuple of payloads
