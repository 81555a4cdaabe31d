"""H_a and u'_a one state at a time (mrnea.actuators.actuator_mass_matrix_and_bias within
``one_state_at_a_time``, what the CLI runs for its retiming's and excitation's efforts), issue 22.

Against Pinocchio (CRBA and RNEA, the wrench included) plus the actuator terms of Eqs. 42-43
written out here (G^2 J_m on the diagonal, F_v qd, F+ / -F- by the sign of qd); against the
public batch function to the bit (the retimed programs unchanged), with a wrench per state and
per link; the errors of the public function; and, on an empty Numba cache, that the CLI's
retiming compiles no batch kernel and no second signature of ``actuator_terms``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import CLI_COMPILES, PinChain, compiled_kernels, random_states, rel_err, to_pinocchio
from test_dynamics_pinocchio import get_case

import mrnea
from mrnea.actuators import actuator_mass_matrix_and_bias, one_state_at_a_time
from mrnea.cli.base import COMPILE_NOTICE
from mrnea.errors import StateError

TOL = 1e-9  # test_dynamics_pinocchio's
ROOT = Path(__file__).resolve().parents[1]


def _with_drives(robot: mrnea.Robot, rng: np.random.Generator) -> mrnea.Robot:
    n = robot.n
    return robot.with_actuators(gear_ratio=rng.uniform(10, 100, n),
                                rotor_inertia=rng.uniform(1e-5, 1e-4, n),
                                viscous_friction=rng.uniform(0.1, 2.0, n),
                                coulomb_friction=rng.uniform(0.1, 3.0, (n, 2)))


def _reference(robot: mrnea.Robot, pc: PinChain, q, qd, fe, pe) -> tuple:
    """Eqs. 42-43 on Pinocchio's H and bias."""
    G, Jm, Fv, F = (robot.gear_ratio, robot.rotor_inertia, robot.viscous_friction,
                    robot.coulomb_friction)
    H = pc.mass_matrix(q) + np.diag(G ** 2 * Jm)
    u = (pc.bias(q, qd, fe, pe) + Fv * qd
         + np.where(qd > 0, F[:, 0], np.where(qd < 0, -F[:, 1], 0.0)))
    return H, u


@pytest.mark.parametrize("name", ["n6-mixed", "ur5"])
def test_one_state_at_a_time_against_pinocchio(name: str) -> None:
    c = get_case(name)
    rng = np.random.default_rng(5)
    robot = _with_drives(c.robot, rng)
    pc = PinChain(robot, to_pinocchio(robot))
    s = random_states(rng, robot, 20)
    s["qd"][0] = 0.0  # at rest: no Coulomb term
    with one_state_at_a_time():
        H, u = actuator_mass_matrix_and_bias(robot, s["q"], s["qd"], s["f_ext"], s["f_ext_point"])
    assert H.shape == (20, robot.n, robot.n) and u.shape == (20, robot.n)
    for b in range(20):
        Hr, ur = _reference(robot, pc, s["q"][b], s["qd"][b], s["f_ext"][b],
                            s["f_ext_point"][b])
        assert rel_err(H[b], Hr) <= TOL
        assert rel_err(u[b], ur) <= TOL


def test_one_state_at_a_time_equals_the_public_batch_to_the_bit() -> None:
    """The same compiled mRNEA, the same Coulomb term: a retiming plans on the numbers it
    planned on before, whichever way they are evaluated (wrench per state, one point for all,
    by link name, none)."""
    robot = mrnea.robots.puma560()
    rng = np.random.default_rng(8)
    s = random_states(rng, robot, 50)
    s["qd"][::3] = 0.0
    s["qd"][1, 2] = -0.0
    links = robot.link_names
    wrenches = [(None, None), (s["f_ext"], s["f_ext_point"][0]),
                ({links[2]: s["f_ext"], links[-1]: s["f_ext"][0]}, {links[2]: [0.0, 0.1, 0.0]})]
    for fe, pe in wrenches:
        with one_state_at_a_time():
            H, u = actuator_mass_matrix_and_bias(robot, s["q"], s["qd"], fe, pe)
        H2, u2 = actuator_mass_matrix_and_bias(robot, s["q"], s["qd"], fe, pe)  # the batch
        assert np.array_equal(H, H2) and np.array_equal(u, u2)
    with one_state_at_a_time():  # one state, not a batch
        H1, u1 = actuator_mass_matrix_and_bias(robot, s["q"][4], s["qd"][4])
    H2, u2 = actuator_mass_matrix_and_bias(robot, s["q"], s["qd"])
    assert np.array_equal(H1, H2[4]) and np.array_equal(u1, u2[4])


def test_every_actuator_effort_follows_it(monkeypatch) -> None:
    """actuator_efforts (the excitation's effort checks) and the retiming's path take H_a and
    u'_a from the one function, so within the block none reaches the batch kernel."""
    import mrnea.actuators as actuators

    robot = mrnea.robots.puma560()
    s = random_states(np.random.default_rng(3), robot, 5)
    want = actuators.actuator_efforts(robot, s["q"], s["qd"], s["qdd"])

    def batch(*args):
        raise AssertionError("the batch kernel")

    monkeypatch.setattr(actuators, "actuator_terms_batch", batch)
    with one_state_at_a_time():
        got = actuators.actuator_efforts(robot, s["q"], s["qd"], s["qdd"])
    assert np.array_equal(got, want)
    with pytest.raises(AssertionError, match="the batch kernel"):  # outside the block
        actuators.actuator_efforts(robot, s["q"], s["qd"], s["qdd"])


def test_one_state_at_a_time_refuses_what_the_public_function_refuses() -> None:
    robot = mrnea.robots.puma560()
    q = np.zeros((4, robot.n))
    q[2, 1] = np.nan
    with one_state_at_a_time():
        with pytest.raises(StateError, match="q: contains NaN"):
            actuator_mass_matrix_and_bias(robot, q, np.zeros_like(q))
        with pytest.raises(StateError, match="batch sizes differ"):
            actuator_mass_matrix_and_bias(robot, np.zeros((4, robot.n)), np.zeros((3, robot.n)))


@pytest.mark.slow
def test_a_fresh_cli_retime_compiles_no_batch_kernel(tmp_path) -> None:
    """On an empty cache (no compile-ahead process): ``actuator_terms`` once, the simulation's
    signature, no parallel batch kernel, and the compile notice said once."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "MRNEA_AHEAD": "0"}
    out = subprocess.run([sys.executable, "-c", CLI_COMPILES, "retime", "puma560",
                          str(ROOT / "examples" / "puma_pick.toml"), "--out",
                          str(tmp_path / "out")], env=env, capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    names = [name for name, _ in compiled_kernels(out.stdout)]
    assert names.count("actuator_terms") == 1
    assert not [k for k in names if k.endswith("_batch")], names
    assert "simulate_cycles" in names and "controllable_sets" in names  # it did compile
    assert out.stderr.count(COMPILE_NOTICE) == 1, out.stderr[-2000:]
