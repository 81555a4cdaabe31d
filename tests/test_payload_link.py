"""A payload on a named link (issue 25): ``--payload KG@LINK[:X,Y,Z]``, a program's ``payload``
key and a payload file's ``link``, on the torso-with-two-arms example. Oracle: Pinocchio's
model of the same URDF with the point mass added to that body's inertia
(``pinocchio.Inertia``), its ``rnea`` at random states.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line, rel_err

import mrnea
from mrnea.errors import RobotFileError
from mrnea.io import RobotOptions, load_robot_spec, parse_payload

pin = pytest.importorskip("pinocchio")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
URDF = EXAMPLES / "waist_two_arms.urdf"


def test_the_three_forms_parse() -> None:
    p = parse_payload("2@hand_l:0,0,0.1")
    assert (p.mass, p.link) == (2.0, "hand_l") and np.array_equal(p.com, [0, 0, 0.1])
    p = parse_payload("1.5@hand_r")
    assert (p.mass, p.link) == (1.5, "hand_r") and not p.com.any()
    p = parse_payload("3@0.1,0,0")  # the last link, as before
    assert p.link is None and np.array_equal(p.com, [0.1, 0, 0])
    for bad, words in (("2@:0,0,1", "no link name"), ("2@hand_l:0,1", "the point after ':'")):
        with pytest.raises(RobotFileError, match=words):
            parse_payload(bad)


def _pin_with_point_mass(link_joint: str, mass: float, com):
    model = pin.buildModelFromUrdf(str(URDF))
    jid = model.getJointId(link_joint)
    model.inertias[jid] = model.inertias[jid] + pin.Inertia(mass, np.asarray(com, float),
                                                            np.zeros((3, 3)))
    return model


@pytest.mark.parametrize(("spec", "joint", "mass", "com"), [
    ("2@hand_l:0.1,0,0.05", "wrist_l", 2.0, [0.1, 0, 0.05]),
    ("1.2@upper_arm_r", "shoulder_roll_r", 1.2, [0, 0, 0]),
    ("0.7@0,0.02,0", "wrist_r", 0.7, [0, 0.02, 0]),  # no link: the last link, hand_r
])
def test_a_payload_on_a_named_link_equals_pinocchio(spec, joint, mass, com) -> None:
    robot = load_robot_spec(str(URDF), options=RobotOptions(payload=parse_payload(spec)))
    model = _pin_with_point_mass(joint, mass, com)
    data = model.createData()
    rng = np.random.default_rng(11)
    for _ in range(8):
        q, qd, qdd = rng.uniform(-1, 1, 9), rng.normal(0, 1, 9), rng.normal(0, 2, 9)
        ref = pin.rnea(model, data, q, qd, qdd)
        assert rel_err(mrnea.inverse_dynamics(robot, q, qd, qdd), ref) < 1e-10


def test_a_program_and_a_payload_file_name_the_link(tmp_path) -> None:
    shutil.copy(URDF, tmp_path / URDF.name)
    (tmp_path / "load.toml").write_text('mass = 2.0\ncom = [0.1, 0, 0.05]\nlink = "hand_l"\n')
    ref = load_robot_spec(str(URDF), options=RobotOptions(payload=parse_payload(
        "2@hand_l:0.1,0,0.05")))
    for payload in ("2@hand_l:0.1,0,0.05", "load.toml"):
        prog = tmp_path / "p.toml"
        prog.write_text(f'[program]\nrobot = "{URDF.name}"\ndt = 0.01\npayload = "{payload}"\n'
                        f'[path]\nprofile = "trapezoidal"\nwaypoints = [{{waist = 0}}, '
                        f'{{waist = 0.2}}]\nvelocity_limit = 1\nacceleration_limit = 1\n')
        assert mrnea.load_program(prog).load_robot().links == ref.links


def test_an_unknown_link_is_one_error_naming_it(tmp_path) -> None:
    with pytest.raises(RobotFileError, match=r"no link named 'hand_x'.*did you mean 'hand_"):
        load_robot_spec(str(URDF), options=RobotOptions(payload=parse_payload("2@hand_x")))
    res = mrnea_cli("check", EXAMPLES / "waist_left_swing.toml", "--payload", "2@hand_x:0,0,0.1")
    one_error_line(res, "'hand_x'", "waist_two_arms")
