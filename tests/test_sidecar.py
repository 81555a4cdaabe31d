"""The sidecar actuator file: what URDF cannot say, given next to a URDF (or a native file)."""

from __future__ import annotations

import numpy as np
import pytest

import mrnea
from mrnea.achievable import achievable_accelerations
from mrnea.errors import RobotFileError

URDF = """<robot name="arm">
  <link name="base"/>
  <link name="l1"><inertial><mass value="2"/><origin xyz="0.2 0 0"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"><inertial><mass value="1"/><origin xyz="0.1 0 0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="40" velocity="2"/><dynamics damping="0.5" friction="1"/>
  </joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.4 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="20" velocity="3"/>
  </joint>
  <transmission name="t1"><type>transmission_interface/SimpleTransmission</type>
    <joint name="j1"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="m1"><mechanicalReduction>50</mechanicalReduction></actuator></transmission>
</robot>
"""


@pytest.fixture()
def urdf(tmp_path):
    p = tmp_path / "arm.urdf"
    p.write_text(URDF)
    return p


def test_urdf_actuator_fields(urdf):
    r = mrnea.load_urdf(urdf)
    assert r.effort_limit.tolist() == [40.0, 20.0]
    assert r.velocity_limit.tolist() == [2.0, 3.0]
    assert r.viscous_friction.tolist() == [0.5, 0.0]
    assert r.coulomb_friction.tolist() == [[1.0, 1.0], [0.0, 0.0]]  # [F+, F-] per joint
    assert r.gear_ratio.tolist() == [50.0, 1.0]
    assert r.rotor_inertia.tolist() == [0.0, 0.0]


def test_sidecar_adds_rotor_inertia_and_a_curve(urdf, tmp_path):
    side = tmp_path / "arm.actuators.toml"
    side.write_text("[j1]\nrotor_inertia = 2e-4\n\n[j2]\ntorque_speed = [30.0, 1.0, 4.0]\n"
                    "gear_ratio = 80\n")
    r = mrnea.load_urdf(urdf, actuators=side)
    assert r.rotor_inertia.tolist() == [2e-4, 0.0]
    assert r.gear_ratio.tolist() == [50.0, 80.0]  # the URDF's transmission is kept
    assert r.torque_speed == (None, (30.0, 1.0, 4.0))
    assert r.effort_limit.tolist() == [40.0, 30.0]
    assert mrnea.load_robot(urdf, actuators=side).torque_speed == r.torque_speed
    # the curve is used at the current speed: at 2 rad/s, min(30 * 1/2, 30 * (4-2)/(4-1)) = 15
    res = achievable_accelerations(r, [0.0, 0.0], [0.0, 2.0], [0.0, 1e4])
    assert res.limit[1] == pytest.approx(15.0)
    # rotor inertia enters H_a as G^2 J_m = 2500 * 2e-4 = 0.5 kg m^2
    from mrnea.actuators import actuator_mass_matrix_and_bias
    Ha, _ = actuator_mass_matrix_and_bias(r, [0.0, 0.0], [0.0, 0.0])
    H, _ = mrnea.mass_matrix_and_bias(r, [0.0, 0.0], [0.0, 0.0])
    np.testing.assert_allclose(Ha - H, np.diag([0.5, 80.0**2 * 0.0]), atol=1e-15)


def test_sidecar_effort_limit_replaces_a_curve(urdf, tmp_path):
    side = tmp_path / "a.toml"
    side.write_text("[j2]\neffort_limit = 12.0\n")
    r = mrnea.load_urdf(urdf, actuators=side).with_actuators(torque_speed=[None, (5, 1, 2)])
    assert r.effort_limit[1] == 5.0
    r2 = r.with_actuators(effort_limit=[40.0, 12.0])
    assert r2.torque_speed == (None, None) and r2.effort_limit[1] == 12.0


@pytest.mark.parametrize(("text", "match"), [
    ("[j3]\ngear_ratio = 2\n", "no joint named 'j3'"),
    ("[j1]\ngear_raito = 2\n", "did you mean 'gear_ratio'"),
    ("[j1]\ngear_ratio = -2\n", "gear_ratio must be > 0"),
    ("[j1]\nrotor_inertia = 'big'\n", "must be a number"),
    ("[j1]\ntorque_speed = [1, 2]\n", "array of 3 numbers"),
    ("[j1]\ntorque_speed = [10, 3, 2]\n", "corner_speed <= no_load_speed"),
    ("[j1]\neffort_limit = 5\ntorque_speed = [10, 1, 2]\n", "differ"),
    ("[j1\n", "invalid TOML"),
])
def test_bad_sidecar(urdf, tmp_path, text, match):
    side = tmp_path / "bad.toml"
    side.write_text(text)
    with pytest.raises(RobotFileError, match=match):
        mrnea.load_urdf(urdf, actuators=side)


def test_missing_sidecar(urdf, tmp_path):
    with pytest.raises(RobotFileError, match="actuator file not found"):
        mrnea.load_urdf(urdf, actuators=tmp_path / "nope.toml")
