"""Extreme numbers in a robot (issue 23): a field beyond the magnitude mrnea accepts
(:data:`mrnea.frozen.MAGNITUDES`: gravity 1e3 m/s^2, lengths 1e4 m, mass 1e7 kg, inertia
1e10 kg m^2, rotor inertia 1e3 kg m^2, friction 1e9) is one ModelError naming the field and the
joint or link, through the API and on the command line (one error line, exit 2), never an internal
error; a value at the bound is accepted. A mass matrix that is too ill-conditioned within those
bounds (a 1e3 kg m^2 rotor behind a 1e6 gear) names the joint whose inertia causes it and the
fields to check, not a joint that "moves no inertia".
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea.errors import ModelError, SingularMassMatrixError
from mrnea.model import Joint, Link, Robot

CORPUS = Path(__file__).parent / "malformed"
BOUNDS = {"gravity": 1e3, "length": 1e4, "mass": 1e7, "inertia": 1e10, "rotor_inertia": 1e3,
          "viscous_friction": 1e9, "coulomb_friction": 1e9}  # docs/robot-format.md


def _build(field: str, value: float) -> Robot:
    """The Puma 560 with ``field`` of its third joint (or link, or the robot's gravity) set to
    ``value``."""
    puma = mrnea.robots.puma560()
    if field == "gravity":
        return puma.with_gravity((0.0, 0.0, -value))
    if field in ("rotor_inertia", "viscous_friction", "coulomb_friction"):
        return puma.with_actuators(**{field: [0.0, 0.0, value, 0.0, 0.0, 0.0]})
    joints, links = list(puma.joints), list(puma.links)
    lk, j = links[2], joints[2]
    if field == "mass":
        links[2] = Link(lk.name, value, lk.com, lk.inertia)
    elif field == "inertia":
        links[2] = Link(lk.name, lk.mass, lk.com, np.diag([value, value, value]))
    elif field == "length":
        origin = np.array(j.origin)
        origin[0, 3] = value
        joints[2] = Joint(j.name, j.type, j.parent, j.child, origin, j.axis)
    return Robot(joints, links, gravity=puma.gravity, name="puma560")


NAMES = {"gravity": ("robot 'puma560'", "gravity"), "length": ("joint 'joint3'", "origin"),
         "mass": ("link 'link3'", "mass"), "inertia": ("link 'link3'", "inertia"),
         "rotor_inertia": ("joint 'joint3'", "rotor inertia"),
         "viscous_friction": ("joint 'joint3'", "viscous friction"),
         "coulomb_friction": ("joint 'joint3'", "coulomb friction")}


@pytest.mark.parametrize("field", list(BOUNDS))
@pytest.mark.parametrize("value", [1e300, "just over"])
def test_a_field_beyond_its_magnitude_is_named(field: str, value: object) -> None:
    v = 1e300 if value == 1e300 else np.nextafter(BOUNDS[field], np.inf)
    with pytest.raises(ModelError) as err:
        _build(field, v)
    msg = str(err.value)
    owner, name = NAMES[field]
    assert msg.startswith(owner) and name in msg and "largest mrnea accepts" in msg, msg
    assert "please report" not in msg


@pytest.mark.parametrize("field", list(BOUNDS))
def test_a_field_at_its_magnitude_is_accepted(field: str) -> None:
    robot = _build(field, BOUNDS[field])
    assert isinstance(robot, Robot)


def test_an_ill_conditioned_mass_matrix_names_the_joint_that_causes_it() -> None:
    """joint3: a 1e3 kg m^2 rotor behind a 1e6 gear reflects G^2 J_m = 1e15 kg m^2 (closed
    form), 1e14 times joint 1's inertia: the error names joint3 and its rotor fields."""
    puma = mrnea.robots.puma560()
    robot = puma.with_actuators(rotor_inertia=[0, 0, 1e3, 0, 0, 0],
                                gear_ratio=[62.6, 107.8, 1e6, 76.0, 71.9, 76.7])
    with pytest.raises(SingularMassMatrixError) as err:
        mrnea.simulate(robot, np.zeros((5, 6)), 0.01)
    msg = str(err.value)
    assert "ill-conditioned" in msg and "joint 'joint3' has 1e+15 kg m^2" in msg, msg
    assert "rotor_inertia and gear_ratio" in msg and "moves no inertia" not in msg


# --- the command line: a robot file with one extreme field --------------------------------------
FILE_FIELDS = {  # the reference arm's elbow (or forearm), a line replaced
    "rotor_inertia": ("viscous_friction = 0.1", "viscous_friction = 0.1\nrotor_inertia = 1e300",
                      "joint 'elbow'"),
    "viscous_friction": ("viscous_friction = 0.1", "viscous_friction = 1e300", "joint 'elbow'"),
    "coulomb_friction": ("coulomb_friction = 0.2", "coulomb_friction = 1e300", "joint 'elbow'"),
    "mass": ("mass = 1.0", "mass = 1e300", "link 'forearm'"),
    "length": ("com = [0.15, 0.0, 0.0]", "com = [1e300, 0.0, 0.0]", "link 'forearm'"),
    "inertia": ("inertia = { ixx = 0.001, iyy = 0.008, izz = 0.008 }",
                "inertia = { ixx = 1e300, iyy = 1e300, izz = 1e300 }", "link 'forearm'"),
    "origin": ("origin = { xyz = [0.4, 0.0, 0.0]", "origin = { xyz = [1e300, 0.0, 0.0]",
               "joint 'elbow'"),
}


@pytest.mark.parametrize("field", [*FILE_FIELDS, "gravity"])
def test_cli_names_the_extreme_field(tmp_path, field: str) -> None:
    text = (CORPUS / "reference_arm.toml").read_text(encoding="utf-8")
    extra: list[str] = []
    if field == "gravity":
        extra, owner = ["--gravity", "0,0,-1e300"], "gravity"
    else:
        old, new, owner = FILE_FIELDS[field]
        assert old in text
        text = text.replace(old, new, 1)
    (tmp_path / "arm.toml").write_text(text, encoding="utf-8")
    res = mrnea_cli("info", "arm.toml", *extra, cwd=tmp_path)
    line = one_error_line(res, owner, "largest mrnea accepts")
    assert "please report" not in line and "internal error" not in line
