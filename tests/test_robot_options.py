"""Payload, gravity, tip and sidecar as robot options; program files that name them; the top-level
exports; the robot description (tables and JSON); tracking errors at the cycle's resolution.

Payload and gravity are checked against Pinocchio (a body appended to the last joint, the model's
gravity set) and against closed forms (a point mass on a horizontal pendulum).
"""

from __future__ import annotations

import importlib
import json
import math
import shutil
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import (
    PinChain,
    erd_path,
    random_chain,
    random_inertia,
    random_states,
    rel_err,
    to_pinocchio,
)

import mrnea
from mrnea.describe import describe, robot_data
from mrnea.errors import ModelError, ProgramFileError, RobotFileError
from mrnea.io import (
    Payload,
    RobotOptions,
    is_program_file,
    load_program,
    load_robot_spec,
    loads_program,
    parse_payload,
)
from mrnea.model import Joint, Link, Robot

UR5 = "ur_description/urdf/ur5_robot.urdf"


# --- payload ----------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(6))
def test_payload_matches_pinocchio_appended_body(seed: int) -> None:
    """with_payload equals Pinocchio's model with the payload appended to the last joint's body:
    the combined inertia (mass, centre of mass, inertia about it) and the dynamics."""
    rng = np.random.default_rng(seed)
    robot = random_chain(rng, 2 + seed)
    m = float(rng.uniform(0.1, 5.0))
    c = rng.uniform(-0.3, 0.3, 3)
    inertia = random_inertia(rng, m) if seed % 2 else None
    ours = robot.with_payload(m, c, inertia)

    model = to_pinocchio(robot)
    payload = pin.Inertia(m, c, np.zeros((3, 3)) if inertia is None else inertia)
    model.appendBodyToJoint(robot.n, payload, pin.SE3.Identity())
    both = model.inertias[robot.n]
    last = ours.links[-1]
    assert last.name == robot.links[-1].name
    assert rel_err(last.mass, both.mass) < 1e-13
    assert rel_err(last.com, np.array(both.lever)) < 1e-13
    assert rel_err(last.inertia, np.array(both.inertia)) < 1e-12
    assert ours.links[:-1] == robot.links[:-1] and ours.joints == robot.joints

    chain = PinChain(ours, model)
    s = random_states(rng, ours)
    assert rel_err(mrnea.inverse_dynamics(ours, s["q"], s["qd"], s["qdd"]),
                   chain.rnea(s["q"], s["qd"], s["qdd"])) < 1e-12
    H, _ = mrnea.mass_matrix_and_bias(ours, s["q"], s["qd"])
    assert rel_err(H, chain.mass_matrix(s["q"])) < 1e-12


def horizontal_pendulum(mass: float = 0.0) -> Robot:
    """One revolute joint about base y, its link along x (a massless rod unless ``mass``, at
    its origin): at q = 0 gravity (-z) pulls the tip straight down."""
    return Robot([Joint("j", "revolute", "base", "rod", axis=(0.0, 1.0, 0.0))],
                 [Link("rod", mass, (0.0, 0.0, 0.0), np.eye(3) * 1e-3)])


def test_point_payload_closed_form() -> None:
    """A point mass m at distance L along the horizontal rod: the static torque about y is
    -m g L (gravity -z, lever +x: r x F = (L, 0, 0) x (0, 0, -m g) = (0, m g L, 0), which the
    joint must cancel); held upside down (gravity +z) it is the opposite."""
    m, L, g = 2.5, 0.7, 9.81
    robot = horizontal_pendulum().with_payload(m, (L, 0.0, 0.0))
    tau = mrnea.inverse_dynamics(robot, [0.0], [0.0], [0.0])
    assert tau[0] == pytest.approx(-m * g * L, rel=1e-14)
    hanging = robot.with_gravity((0.0, 0.0, g))
    assert mrnea.inverse_dynamics(hanging, [0.0], [0.0], [0.0])[0] == pytest.approx(
        m * g * L, rel=1e-14)
    # accelerating it: the point mass adds m L^2 to the joint's inertia
    qdd = 3.0
    tau_acc = mrnea.inverse_dynamics(robot.with_gravity((0.0, 0.0, 0.0)), [0.0], [0.0], [qdd])
    assert tau_acc[0] == pytest.approx((1e-3 + m * L * L) * qdd, rel=1e-14)


def test_payload_inertia_about_its_own_centre() -> None:
    """A rod payload of inertia I about its centre at distance L: joint inertia I_yy + m L^2."""
    m, L, Iyy = 1.2, 0.4, 0.05
    robot = horizontal_pendulum().with_gravity((0.0, 0.0, 0.0)).with_payload(
        m, (L, 0.0, 0.0), np.diag([0.01, Iyy, 0.02]))
    H, _ = mrnea.mass_matrix_and_bias(robot, [0.3], [0.0])
    assert H[0, 0] == pytest.approx(1e-3 + Iyy + m * L * L, rel=1e-14)


@pytest.mark.parametrize("args, match", [
    ((-1.0,), "with_payload: .*mass must be >= 0"),
    ((1.0, (0.0, 0.0)), "with_payload: .*centre of mass"),
    ((1.0, (0, 0, 0), np.diag([1.0, 1.0, -1.0])), "with_payload: .*positive semi-definite"),
    ((math.nan,), "with_payload"),
])
def test_payload_bad_arguments(args: tuple, match: str) -> None:
    with pytest.raises(ModelError, match=match):
        horizontal_pendulum(1.0).with_payload(*args)


def test_parse_payload_forms(tmp_path) -> None:
    p = parse_payload("2.5")
    assert p.mass == 2.5 and not p.com.any() and not p.inertia.any()
    p = parse_payload("2.5@0,0,0.1")
    assert p.mass == 2.5 and p.com.tolist() == [0.0, 0.0, 0.1]
    (tmp_path / "tool.toml").write_text(
        'mass = 1.5\ncom = [0.0, 0.0, 0.05]\ninertia = { ixx = 0.002, iyy = 0.003, izz = 0.001, '
        'ixy = 0.0001 }\n')
    p = parse_payload("tool.toml", base_dir=tmp_path)
    assert p.mass == 1.5 and p.com.tolist() == [0.0, 0.0, 0.05]
    np.testing.assert_array_equal(p.inertia, [[0.002, 0.0001, 0.0], [0.0001, 0.003, 0.0],
                                              [0.0, 0.0, 0.001]])
    for bad, match in [("-1", "mass must be a number >= 0"), ("1@0,0", "3 finite numbers"),
                       ("1@a,b,c", "3 finite numbers"), ("heavy", "neither a mass"),
                       ("1@0,0,inf", "3 finite numbers")]:
        with pytest.raises(RobotFileError, match=match):
            parse_payload(bad)
    (tmp_path / "bad.toml").write_text("mass = 1.0\nvolume = 2.0\n")
    with pytest.raises(RobotFileError, match=r"bad.toml: top level: unknown key 'volume'"):
        parse_payload(str(tmp_path / "bad.toml"))
    (tmp_path / "neg.toml").write_text("mass = 1.0\ninertia = [[1, 0, 0], [0, 1, 0], [0, 0, -1]]\n")
    with pytest.raises(RobotFileError, match=r"neg.toml: .*positive semi-definite"):
        parse_payload(str(tmp_path / "neg.toml"))


# --- gravity ----------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(4))
def test_ceiling_mounted_gravity_flips_the_gravity_torques(seed: int) -> None:
    """with_gravity((0, 0, +g)) matches Pinocchio with model.gravity set so, and its static
    torques are exactly the floor-mounted ones with the sign flipped."""
    rng = np.random.default_rng(100 + seed)
    floor = random_chain(rng, 3 + seed)
    ceiling = floor.with_gravity((0.0, 0.0, 9.81))
    assert ceiling.gravity.tolist() == [0.0, 0.0, 9.81] and ceiling.links == floor.links
    model = to_pinocchio(floor)
    model.gravity = pin.Motion(np.array([0.0, 0.0, 9.81, 0.0, 0.0, 0.0]))
    chain = PinChain(ceiling, model)
    zero = np.zeros(floor.n)
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, floor.n)
        up = mrnea.inverse_dynamics(ceiling, q, zero, zero)
        assert rel_err(up, chain.rnea(q, zero, zero)) < 1e-12
        np.testing.assert_allclose(up, -mrnea.inverse_dynamics(floor, q, zero, zero),
                                   rtol=0, atol=1e-12 * max(1.0, np.abs(up).max()))


# --- options, program keys, robots named by programs --------------------------------------------
def test_options_override_field_by_field() -> None:
    program = RobotOptions(actuators="a.toml", payload=Payload(1.0, np.zeros(3), np.zeros((3, 3))),
                           gravity=(0.0, 0.0, 9.81))
    cli = RobotOptions(payload=Payload(5.0, np.zeros(3), np.zeros((3, 3))), tip="flange")
    merged = cli.over(program)
    assert merged.actuators == "a.toml" and merged.tip == "flange"
    # payloads are a tuple (one Payload given: a tuple of one), replaced as a whole
    assert [p.mass for p in merged.payload] == [5.0] and merged.gravity == (0.0, 0.0, 9.81)


def test_load_robot_spec_applies_every_option(tmp_path) -> None:
    """Sidecar, payload and gravity on a URDF, in the documented order."""
    urdf = erd_path(UR5)
    (tmp_path / "drives.toml").write_text(
        "[wrist_3_joint]\nrotor_inertia = 1.3e-5\ngear_ratio = 101.0\n"
        "torque_speed = [28.0, 2.5, 3.4]\n")
    plain = mrnea.load_urdf(urdf)
    robot = load_robot_spec(str(urdf), options=RobotOptions(
        actuators=str(tmp_path / "drives.toml"), payload=parse_payload("2@0,0,0.1"),
        gravity=(0.0, 0.0, 9.81)))
    assert robot.joints[5].torque_speed == (28.0, 2.5, 3.4)
    assert robot.joints[5].rotor_inertia == 1.3e-5 and robot.joints[5].gear_ratio == 101.0
    assert robot.links[-1].mass == pytest.approx(plain.links[-1].mass + 2.0, rel=1e-15)
    assert robot.gravity.tolist() == [0.0, 0.0, 9.81]
    with pytest.raises(RobotFileError, match="tip 'x' chooses a URDF tree's chain"):
        load_robot_spec("puma560", options=RobotOptions(tip="x"))


def test_unknown_robot_and_xacro_messages(tmp_path) -> None:
    with pytest.raises(RobotFileError, match=r"'ur5' is neither a built-in robot "
                                             r"\(sdt, puma560\) nor a file"):
        load_robot_spec("ur5")
    x = tmp_path / "arm.urdf.xacro"
    x.write_text("<robot/>")
    with pytest.raises(RobotFileError, match=r"xacro .*'xacro arm.urdf.xacro > arm.urdf'"):
        load_robot_spec(str(x))


def write_program(path, robot: str | None, waypoints: str, extra: str = "") -> None:
    lines = ["[program]"]
    if robot is not None:
        lines.append(f'robot = "{robot}"')
    lines += ["dt = 0.01", extra, "[path]", 'profile = "quintic"', f"waypoints = {waypoints}",
              "velocity_limit = 1.0", "acceleration_limit = 2.0", "dwell = 0.05"]
    path.write_text("\n".join(lines) + "\n")


def test_program_names_its_robot_and_options(tmp_path) -> None:
    """A program's robot, sidecar and payload are relative to the program's folder; the robot
    given besides it must be the same file (under any path); the options it names apply."""
    (tmp_path / "robots").mkdir()
    urdf = tmp_path / "robots" / "ur5.urdf"
    shutil.copy(erd_path(UR5), urdf)
    (tmp_path / "progs").mkdir()
    (tmp_path / "progs" / "drives.toml").write_text("[elbow_joint]\ngear_ratio = 50.0\n")
    prog_path = tmp_path / "progs" / "p.toml"
    write_program(prog_path, "../robots/ur5.urdf", "[[0, 0, 0, 0, 0, 0], [0.1, 0, 0, 0, 0, 0]]",
                  'actuators = "drives.toml"\npayload = "1.5@0,0,0.1"\ngravity = [0, 0, 9.81]')
    assert is_program_file(prog_path) and not is_program_file(urdf)
    prog = load_program(prog_path)
    robot = prog.load_robot()
    assert robot.joints[2].gear_ratio == 50.0 and robot.gravity.tolist() == [0.0, 0.0, 9.81]
    base_mass = mrnea.load_urdf(urdf).links[-1].mass
    assert robot.links[-1].mass == pytest.approx(base_mass + 1.5, rel=1e-15)
    # the same file under another path is the same robot; options given override the program's
    again = prog.load_robot(str(tmp_path / "progs" / ".." / "robots" / "ur5.urdf"),
                            RobotOptions(payload=parse_payload("4")))
    assert again.links[-1].mass == pytest.approx(base_mass + 4.0, rel=1e-15)
    assert again.joints[2].gear_ratio == 50.0
    with pytest.raises(ProgramFileError, match=r"robot 'puma560' is not the robot .*p.toml "
                                               r"names \(.*ur5.urdf\)"):
        prog.load_robot("puma560")


def test_program_without_robot_and_joint_counts(tmp_path) -> None:
    p = tmp_path / "ur5_fast.toml"
    write_program(p, None, "[[0, 0, 0, 0, 0], [0.1, 0, 0, 0, 0]]")
    prog = load_program(p)
    assert prog.robot is None
    with pytest.raises(ProgramFileError, match="names no robot"):
        prog.load_robot()
    with pytest.raises(ProgramFileError,
                       match=r"ur5_fast.toml: 5 joint values per waypoint, robot ur5 has 6$"):
        prog.load_robot(str(erd_path(UR5)))
    q = tmp_path / "path.csv"
    q.write_text("t,a,b\n0,0,0\n0.1,0.1,0\n")
    (tmp_path / "csvprog.toml").write_text('[program]\ndt = 0.01\n[path]\ncsv = "path.csv"\n')
    with pytest.raises(ProgramFileError,
                       match=r"csvprog.toml: its CSV path path.csv has 2 joint columns, robot "
                             r"puma560 has 6$"):
        load_program(tmp_path / "csvprog.toml").load_robot("puma560")


def test_robot_and_program_files_say_which_they_are(tmp_path) -> None:
    prog = tmp_path / "p.toml"
    write_program(prog, "puma560", "[[0, 0, 0, 0, 0, 0], [0.1, 0, 0, 0, 0, 0]]")
    with pytest.raises(RobotFileError, match=r"p.toml: a program file \(it has a \[program\] "
                                             r"table\), not a robot file"):
        mrnea.load_robot(prog)
    robot_file = tmp_path / "r.toml"
    robot_file.write_text('[robot]\nname = "r"\n[[joint]]\nname = "j"\ntype = "revolute"\n'
                          'axis = [0, 0, 1]\n[joint.link]\nmass = 1.0\n')
    with pytest.raises(ProgramFileError, match=r"r.toml: a robot file \(it has no \[program\] "
                                               r"table\), not a program"):
        load_program(robot_file)


@pytest.mark.parametrize("text, match", [
    ('payload = 2.5', "'payload' must be a non-empty string"),
    ('payload = "2.5@1,2"', r"\[program\]: payload '2.5@1,2'.*3 finite numbers"),
    ('gravity = [0, 9.81]', "'gravity' must be an array of 3 numbers"),
    ('tip = ""', "'tip' must be a non-empty string"),
    ('actuator = "x.toml"', "did you mean 'actuators'"),
])
def test_program_option_errors(text: str, match: str) -> None:
    doc = f'[program]\ndt = 0.01\n{text}\n[path]\nprofile = "quintic"\nwaypoints = [[0], [1]]\n' \
          'velocity_limit = 1.0\nacceleration_limit = 1.0\n'
    with pytest.raises(ProgramFileError, match=match):
        loads_program(doc, "prog.toml")


# --- top-level exports ----------------------------------------------------------------------------
def test_top_level_exports_and_the_simulate_module() -> None:
    from mrnea.achievable import achievable_accelerations
    from mrnea.cartesian import load_program as cartesian_load_program
    from mrnea.simulate import SimulationResult, simulate

    assert mrnea.simulate is simulate and callable(mrnea.simulate)
    assert mrnea.achievable_accelerations is achievable_accelerations
    # the public loader is the one that also solves a Cartesian program's moves
    assert mrnea.load_program is cartesian_load_program
    module = importlib.import_module("mrnea.simulate")
    assert module.simulate is simulate and module.SimulationResult is SimulationResult
    assert {"simulate", "achievable_accelerations", "load_program"} <= set(mrnea.__all__)


# --- description ------------------------------------------------------------------------------
def test_describe_fits_the_width_and_json_is_strict() -> None:
    """Every table line fits the width (the legend wraps); unlimited values are JSON null."""
    robot = mrnea.load_urdf(erd_path("panda_description/urdf/panda.urdf"), tip="panda_hand_tcp")
    robot = robot.with_actuators(torque_speed=(87.0, 2.0, math.inf))
    for width in (60, 80, 100, 250):
        text = describe(robot, width)
        assert all(len(line) <= width for line in text.splitlines()), width
        for name in robot.joint_names:
            assert name in text
        assert "curve [N m, rad/s]" in text and "87/2/inf" in text
    data = json.loads(json.dumps(robot_data(robot), allow_nan=False))
    j = data["joints"][0]
    assert j["torque_speed"] == {"peak": 87.0, "corner_speed": 2.0, "no_load_speed": None}
    assert j["units"] == {"q": "rad", "qd": "rad/s", "qdd": "rad/s^2", "tau": "N m"}
    sdt = robot_data(mrnea.robots.sdt())
    assert sdt["joints"][0]["lower"] is None and sdt["joints"][0]["upper"] is None


def test_describe_units_follow_the_joint_types() -> None:
    slider = Robot([Joint("s", "prismatic", "base", "carriage", lower=0.0, upper=0.5,
                          effort_limit=100.0, viscous_friction=3.0)],
                   [Link("carriage", 2.0, (0.0, 0.0, 0.0), np.eye(3) * 1e-3)])
    text = describe(slider, 200)
    for head in ("lower [m]", "vel limit [m/s]", "effort [N]", "F_v [N s/m]", "F_s [N]",
                 "curve [N, m/s]"):
        assert head in text
    mixed = mrnea.robots.puma560()
    mixed = Robot([*mixed.joints[:2], Joint("s", "prismatic", "link2", "carriage")],
                  [*mixed.links[:2], Link("carriage", 1.0, (0.0, 0.0, 0.0), np.eye(3) * 1e-3)])
    assert "lower [rad or m]" in describe(mixed, 300) and "effort [N m or N]" in describe(mixed,
                                                                                        300)


# --- tracking errors ------------------------------------------------------------------------------
def test_tracking_errors_at_the_cycle_resolution() -> None:
    """A program every joint follows reports exactly 0 tracking error (not 1e-24 rad), and no
    final position line; a saturated one keeps its lag, states it per joint with units."""
    from mrnea.trajectory import quintic

    robot = mrnea.robots.puma560()
    home = np.array([0.0, 0.785, -2.356, 0.0, -0.785, 0.0])
    _, q = quintic([home, home + 0.3], dt=0.005, velocity_limit=1.0, acceleration_limit=2.0)
    res = mrnea.simulate(robot, q, 0.005)
    assert res.achievable
    raw = res.q_cmd - res.q
    bound = 1e-12 * np.maximum(1.0, np.abs(q).max(axis=0))
    assert (np.abs(raw) <= bound).all()  # the rule's premise: rounding only
    assert not res.tracking_error.any() and res.summary()["max_tracking_error"] == 0.0
    assert res.final_position_line() is None
    weak = robot.with_actuators(effort_limit=[97.6, 5.0, 89.4, 24.2, 20.1, 21.3])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lag = mrnea.simulate(weak, q, 0.005)
    assert not lag.achievable and lag.tracking_error[-1, 1] != 0.0
    line = lag.final_position_line()
    assert line.startswith("The robot did not reach the program's end: final position error ")
    assert f"joint2 {lag.tracking_error[-1, 1]:.4g} rad" in line and "joint1 0 rad" in line
    # the verdict (issue 11): the worst joint's requirement against its limit, with units
    verdict = lag.verdict()
    assert verdict.startswith("NOT ACHIEVABLE: joint2 needs ") and "N m limit" in verdict
