"""The gear's efficiency in the drive model (issue 27): the effort box of a cycle, the motor-side
torque, the field in every input (with_actuators, sidecar, native file) and, with efficiency 1,
today's results bit for bit.

Oracles: the closed forms of a one-joint rotor (H_a = I_zz + G^2 J_m, no gravity, no friction:
qdd = tau / H_a), the definitions of the issue (joint-side limit eta_d L driving, L / eta_b
back-driven; motor torque tau / (G eta_d) driving, tau eta_b / G back-driven), and sha256
digests of every array of the demo and the Puma example computed by mrnea at main a30f577,
before efficiency existed.
"""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea import Joint, Link, Robot, robots
from mrnea.achievable import achievable_accelerations
from mrnea.actuators import motor_torque
from mrnea.errors import ModelError
from mrnea.io.program import load_program
from mrnea.robots.sdt_profile import training_profile
from mrnea.trajectory import trapezoidal

ROOT = Path(__file__).resolve().parents[1]

IZZ, G, JM, L = 0.5, 40.0, 2e-4, 30.0  # kg m^2, -, kg m^2, N m (joint side, ideal gear)
HA = IZZ + G**2 * JM


def rotor(efficiency) -> Robot:
    """One revolute joint about the vertical: H_a = IZZ + G^2 J_m, u'_a = 0."""
    j = Joint("j", "revolute", "base", "l", effort_limit=L, gear_ratio=G, rotor_inertia=JM,
              efficiency=efficiency)
    return Robot([j], [Link("l", 1.0, inertia=np.diag([0.3, 0.3, IZZ]))], gravity=(0, 0, 0))


@pytest.mark.parametrize("mode", ["hybrid", "paper"])
def test_effort_box_closed_form(mode):
    """Braking at speed meets L / eta_b, accelerating eta_d L, at rest eta_d L both ways."""
    eta_d, eta_b = 0.8, 0.6
    r = rotor([eta_d, eta_b])
    cases = [  # qd, qdd_des, the effort the drive gives (saturated), driving?
        (2.0, -1e4, -L / eta_b, False), (2.0, 1e4, eta_d * L, True),
        (-2.0, 1e4, L / eta_b, False), (-2.0, -1e4, -eta_d * L, True),
        (0.0, 1e4, eta_d * L, True), (0.0, -1e4, -eta_d * L, True)]
    for qd, qdd_des, tau, driving in cases:
        res = achievable_accelerations(r, [0.3], [qd], [qdd_des], mode=mode)
        assert res.saturated[0]
        np.testing.assert_allclose(res.tau, [tau], rtol=1e-15)
        np.testing.assert_allclose(res.qdd, [tau / HA], rtol=1e-13)
        np.testing.assert_allclose(res.limit, [abs(tau)], rtol=1e-15)
        motor = tau / (G * eta_d) if driving else tau * eta_b / G
        np.testing.assert_allclose(res.tau_motor, [motor], rtol=1e-15)
    # within the box: on the program, the motor torque by the same law
    res = achievable_accelerations(r, [0.3], [2.0], [-50.0], mode=mode)
    assert not res.saturated[0]
    np.testing.assert_allclose(res.tau, [-50.0 * HA], rtol=1e-14)
    np.testing.assert_allclose(res.tau_motor, [-50.0 * HA * eta_b / G], rtol=1e-14)


def test_motor_torque_and_requirement_limit():
    """mrnea.motor_torque over a batch, and the program's requirement measured against the
    side of its box (simulate's program_limit)."""
    r = rotor([0.9, 0.5])
    tau = np.array([[3.0], [-3.0], [3.0], [-3.0], [2.0]])
    qd = np.array([[1.0], [1.0], [-1.0], [-1.0], [0.0]])
    want = [3 / (G * 0.9), -3 * 0.5 / G, 3 * 0.5 / G, -3 / (G * 0.9), 2 / (G * 0.9)]
    np.testing.assert_allclose(motor_torque(r, tau, qd)[:, 0], want,
                               rtol=1e-15)
    # a move 0 -> 1 rad, trapezoidal: accelerating (driving) then braking (back-driven)
    dt = 0.01
    _, q = trapezoidal([[0.0], [1.0]], dt, [2.0], [20.0])
    res = mrnea.simulate(r, q, dt)
    req, lim, qdc = res.program_effort[:, 0], res.program_limit[:, 0], res.qd_cmd[:, 0]
    back = req * qdc < 0
    assert back.any() and (~back & (req != 0)).any()
    np.testing.assert_array_equal(lim[back], L / 0.5)
    np.testing.assert_array_equal(lim[~back], 0.9 * L)
    # the summary's motor side of the requirement, by the law
    motor = np.where(back, req * 0.5 / G, req / (G * 0.9))
    j = res.summary()["joints"][0]
    assert j["program_peak_motor_torque"] == pytest.approx(np.abs(motor).max(), rel=1e-14)
    assert j["program_rms_motor_torque"] == pytest.approx(np.sqrt(np.mean(motor**2)),
                                                          rel=1e-14)


def test_efficiency_field_inputs(tmp_path):
    r = rotor(1.0)
    assert r.with_actuators(efficiency=0.7).efficiency.tolist() == [[0.7, 0.7]]
    assert r.with_actuators(efficiency=[[0.9, 0.6]]).efficiency.tolist() == [[0.9, 0.6]]
    assert r.with_actuators(efficiency=[(0.8, 0.8)]).joints[0].efficiency == 0.8  # one number
    for bad in (0.0, 1.5, -0.2, [0.9, 1.2], float("nan")):
        with pytest.raises(ModelError, match="efficiency"):
            Joint("j", "revolute", "b", "l", efficiency=bad)
    # the native file writes and reads it back, bit for bit
    two = r.with_actuators(efficiency=[[0.83, 0.71]])
    path = two.to_toml(tmp_path / "r.toml")
    assert "efficiency = [0.83, 0.71]" in path.read_text()
    assert mrnea.load_robot(path) == two
    # the sidecar sets it; a bad value is one error line naming the joint, exit 2
    urdf = tmp_path / "r.urdf"
    two.to_urdf(urdf)
    side = tmp_path / "drives.toml"
    side.write_text("[j]\nefficiency = [0.9, 0.8]\n")
    assert mrnea.load_urdf(urdf, actuators=side).efficiency.tolist() == [[0.9, 0.8]]
    side.write_text("[j]\nefficiency = 1.3\n")
    prog = tmp_path / "p.toml"
    prog.write_text('[program]\ndt = 0.01\n[path]\nprofile = "trapezoidal"\n'
                    'waypoints = [[0.0], [0.5]]\nvelocity_limit = [1.0]\n'
                    'acceleration_limit = [5.0]\n')
    one_error_line(mrnea_cli("check", urdf, prog, "--actuators", side), "j", "efficiency")


def _digest(res) -> str:
    h = hashlib.sha256()
    for f in dataclasses.fields(res):
        a = getattr(res, f.name)
        if isinstance(a, np.ndarray):
            h.update(f.name.encode())
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


#: every array of these runs at main a30f577 (before efficiency), by this test's _digest run
#: on that commit's src/ (the summary's keys have grown since, so it is not in the digest)
BEFORE = {
    "sdt_hybrid": "0b6422fa4e44953a372a215e37b990734ff95d462387576eae34082672ad3f04",
    "sdt_paper": "7ff7ca90e2ef00f29b73cd75df22c479d9d317f9b9b1a90c803dfe9e5150b72e",
    "puma_hybrid": "1ac4d8b97491391e07b348150024f7eb3fecbaf43c9b319842ba563238dc7a3c",
    "puma_paper": "dab1e16b4952a4d98fbb717c0ab493ad7f423461613d7c52e3669b2cf4cc007b",
}


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["hybrid", "paper"])
def test_efficiency_one_is_todays_results_bit_for_bit(mode):
    _, q = training_profile(0.005)
    assert _digest(mrnea.simulate(robots.sdt(), q, 0.005, mode=mode)) == BEFORE[f"sdt_{mode}"]
    prog = load_program(ROOT / "examples" / "puma_pick.toml")
    res = mrnea.simulate(prog.load_robot(), prog.q_cmd, prog.dt, mode=mode, f_ext=prog.f_ext,
                         f_ext_point=prog.f_ext_point)
    assert _digest(res) == BEFORE[f"puma_{mode}"]
