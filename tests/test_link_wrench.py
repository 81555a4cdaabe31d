"""Wrenches on any named link (issue 25): ``f_ext={link: [f; n]}`` with points in each link's
frame, on two tree robots (the torso with two arms of examples/, Baxter of example-robot-data).
Oracle: Pinocchio's model of the same URDF (``pinocchio.buildModelFromUrdf``), its ``rnea`` and
``aba`` with ``fext``, a force per joint built here from Pinocchio's own link poses
(``data.oMi``): ours is what the link exerts on its environment, in base coordinates, at a
point of the link; Pinocchio's the force applied to the body, in the joint's local frame, about
its origin, so body i receives ``-[R^T f; R^T n + p x R^T f]``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import PinChain, erd_path, mrnea_cli, one_error_line, pin_from_urdf, rel_err

import mrnea
from mrnea.errors import StateError

pin = pytest.importorskip("pinocchio")

URDF = Path(__file__).resolve().parents[1] / "examples" / "waist_two_arms.urdf"
BAXTER = ("baxter_description/urdf/baxter.urdf",
          ("head", "right_wrist", "left_wrist", "r_gripper_l_finger", "l_gripper_l_finger"))


def _robot(which: str):
    if which == "waist":
        robot = mrnea.load_urdf(URDF)
        return robot, pin_from_urdf(URDF, robot), ("hand_l", "upper_arm_r")
    path = erd_path(BAXTER[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = mrnea.load_urdf(path, tip=BAXTER[1])
    return robot, pin_from_urdf(path, robot), ("left_wrist", "right_lower_elbow")


def _pin_fext(pc: PinChain, robot, q, f_ext: dict, f_ext_point: dict) -> list:
    pin.forwardKinematics(pc.model, pc.data, pc.config(q))
    out = [pin.Force.Zero() for _ in range(pc.model.njoints)]
    for link, w in f_ext.items():
        jid = pc.ids[robot.link_names.index(link)]
        R = pc.data.oMi[jid].rotation
        f, n = R.T @ w[:3], R.T @ w[3:]
        out[jid] = pin.Force(-f, -(n + np.cross(f_ext_point.get(link, np.zeros(3)), f)))
    return out


def _states(robot, rng):
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    return rng.uniform(lo, hi), rng.normal(0, 1, robot.n), rng.normal(0, 2, robot.n)


@pytest.mark.parametrize("which", ["waist", "baxter"])
def test_wrenches_on_two_links_equal_pinocchio(which) -> None:
    robot, model, links = _robot(which)
    assert all(link in robot.link_names for link in links)
    pc = PinChain(robot, model)
    rng = np.random.default_rng(5)
    for _ in range(4):
        q, qd, qdd = _states(robot, rng)
        f_ext = {link: rng.normal(0, 20, 6) for link in links}
        f_pt = {links[0]: rng.normal(0, 0.1, 3)}  # the second at its link's origin
        fext = _pin_fext(pc, robot, q, f_ext, f_pt)
        conf, v = pc.config(q), pc.vel(qd)
        tau = mrnea.inverse_dynamics(robot, q, qd, qdd, f_ext, f_pt)
        ref = pc.ours(pin.rnea(model, pc.data, conf, v, pc.vel(qdd), fext))
        assert rel_err(tau, ref) < 1e-10
        # the wrench is not a no-op: without it the efforts differ
        assert rel_err(mrnea.inverse_dynamics(robot, q, qd, qdd), ref) > 1e-3
        _, u = mrnea.mass_matrix_and_bias(robot, q, qd, f_ext, f_pt)
        u_ref = pc.ours(pin.rnea(model, pc.data, conf, v, np.zeros(model.nv), fext))
        assert rel_err(u, u_ref) < 1e-10
        trq = rng.normal(0, 10, robot.n)
        qdd_ref = pc.ours(pin.aba(model, pc.data, conf, v, pc.vel(trq), fext))
        for method in ("mrnea", "walker_orin", "crba", "aba"):
            qdd_ours = mrnea.forward_dynamics(robot, q, qd, trq, f_ext, f_pt, method=method)
            assert rel_err(qdd_ours, qdd_ref) < 1e-10, method


def test_a_batch_and_a_simulation_take_wrenches_by_link() -> None:
    """A batch of states with a wrench per state equals its states one by one; a simulation's
    simulation with a per-cycle wrench by link, holding a pose, applies Pinocchio's rnea."""
    robot, model, links = _robot("waist")
    pc = PinChain(robot, model)
    rng = np.random.default_rng(9)
    Q = np.stack([_states(robot, rng)[0] for _ in range(3)])
    W = {links[0]: rng.normal(0, 20, (3, 6)), links[1]: rng.normal(0, 20, 6)}
    P = {links[0]: [0.0, 0.0, 0.1]}
    out = mrnea.inverse_dynamics(robot, Q, np.zeros(robot.n), np.zeros(robot.n), W, P)
    for b in range(3):
        f_b = {links[0]: W[links[0]][b], links[1]: W[links[1]]}
        ref = pc.ours(pin.rnea(model, pc.data, pc.config(Q[b]), np.zeros(robot.n),
                               np.zeros(robot.n), _pin_fext(pc, robot, Q[b], f_b, P)))
        assert rel_err(out[b], ref) < 1e-10
    # a held pose, frictionless drives that can hold it: every cycle's effort is gravity plus
    # the wrenches
    stiff = robot.with_actuators(viscous_friction=0.0, coulomb_friction=0.0, rotor_inertia=0.0,
                                 effort_limit=1e6)
    q0, K = Q[0], 4
    f_ext = {links[0]: np.tile(W[links[0]][0], (K, 1)), links[1]: W[links[1]]}
    res = mrnea.simulate(stiff, np.tile(q0, (K, 1)), 0.01, f_ext=f_ext, f_ext_point=P,
                         reactions=False)
    f_0 = {links[0]: W[links[0]][0], links[1]: W[links[1]]}
    ref = pc.ours(pin.rnea(model, pc.data, pc.config(q0), np.zeros(robot.n), np.zeros(robot.n),
                           _pin_fext(pc, robot, q0, f_0, P)))
    for k in range(K):
        assert rel_err(res.tau[k], ref) < 1e-10


def test_wrong_wrenches_by_link_are_one_error_naming_them() -> None:
    robot, _, _ = _robot("waist")
    z = np.zeros(robot.n)
    with pytest.raises(StateError, match=r"no link named 'hand_x'.*did you mean 'hand_"):
        mrnea.inverse_dynamics(robot, z, z, z, {"hand_x": np.ones(6)})
    with pytest.raises(StateError, match=r"f_ext_point: a point for link 'hand_r'"):
        mrnea.inverse_dynamics(robot, z, z, z, {"hand_l": np.ones(6)}, {"hand_r": [0, 0, 1]})
    with pytest.raises(StateError, match=r"f_ext_point: with the wrench given by link name"):
        mrnea.inverse_dynamics(robot, z, z, z, {"hand_l": np.ones(6)}, [0, 0, 1])
    with pytest.raises(StateError, match=r"f_ext\['hand_l'\]: expected shape \(6,\)"):
        mrnea.inverse_dynamics(robot, z, z, z, {"hand_l": np.ones(5)})
    with pytest.raises(StateError, match=r"f_ext\['hand_l'\]: contains NaN"):
        mrnea.forward_dynamics(robot, z, z, z, {"hand_l": [np.nan, 0, 0, 0, 0, 0]})


# --- programs, payloads and the command line ------------------------------------------------------

HOLD = {"shoulder_pitch_l": 0.3, "elbow_l": 0.5, "shoulder_roll_r": -0.4, "elbow_r": 0.6}
W_L, P_L = [1.0, -2.0, 3.0, 0.1, 0.2, -0.3], [0.0, 0.0, 0.05]
W_R = [-2.0, 1.0, 0.5, 0.0, 0.3, 0.0]


def _hold_program(folder: Path, wrenches: str, extra: str = "") -> Path:
    import shutil

    shutil.copy(URDF, folder / URDF.name)
    names = ", ".join(f"{k} = {v}" for k, v in HOLD.items())
    path = folder / "hold.toml"
    path.write_text(f'[program]\nrobot = "{URDF.name}"\ndt = 0.01\n{extra}\n[path]\n'
                    f'profile = "trapezoidal"\nwaypoints = [{{{names}}}]\nvelocity_limit = 1\n'
                    f'acceleration_limit = 1\ndwell = 0.05\n\n{wrenches}')
    return path


TWO_WRENCHES = (f'[[wrench]]\nlink = "hand_l"\ntimes = [0.0, 0.05]\nvalues = [{W_L}, {W_L}]\n'
                f'point = {P_L}\n\n[[wrench]]\nlink = "upper_arm_r"\ntimes = [0.0]\n'
                f'values = [{W_R}]\n')


def _pin_with_masses(masses) -> tuple:
    """Pinocchio's model of the URDF with point masses (joint, kg, com) added to those bodies."""
    robot = mrnea.load_urdf(URDF)
    model = pin_from_urdf(URDF, robot)
    for joint, mass, com in masses:
        jid = model.getJointId(joint)
        model.inertias[jid] = model.inertias[jid] + pin.Inertia(mass, np.asarray(com, float),
                                                                np.zeros((3, 3)))
    return robot, model


def test_several_payloads_equal_pinocchio_with_their_inertias(tmp_path) -> None:
    from mrnea.io import RobotOptions, load_robot_spec, parse_payload

    (tmp_path / "box.toml").write_text('mass = 1.5\ncom = [0.0, 0.01, 0.02]\nlink = "forearm_r"\n'
                                       'inertia = { ixx = 0.01, iyy = 0.02, izz = 0.03 }\n')
    loads = (parse_payload("2@hand_l:0.1,0,0.05"), parse_payload("0.7@upper_arm_r"),
             parse_payload(str(tmp_path / "box.toml")))
    robot = load_robot_spec(str(URDF), options=RobotOptions(payload=loads))
    bare, model = _pin_with_masses([("wrist_l", 2.0, [0.1, 0, 0.05]),
                                    ("shoulder_roll_r", 0.7, [0, 0, 0])])
    jid = model.getJointId("elbow_r")
    model.inertias[jid] = model.inertias[jid] + pin.Inertia(1.5, np.array([0.0, 0.01, 0.02]),
                                                            np.diag([0.01, 0.02, 0.03]))
    pc = PinChain(robot, model)
    rng = np.random.default_rng(3)
    for _ in range(4):
        q, qd, qdd = _states(robot, rng)
        ref = pc.ours(pin.rnea(model, pc.data, pc.config(q), pc.vel(qd), pc.vel(qdd)))
        assert rel_err(mrnea.inverse_dynamics(robot, q, qd, qdd), ref) < 1e-10
        assert rel_err(mrnea.inverse_dynamics(bare, q, qd, qdd), ref) > 1e-3
    # a program's list of payloads is the same robot
    prog = _hold_program(tmp_path, "", 'payload = ["2@hand_l:0.1,0,0.05", "0.7@upper_arm_r", '
                                       '"box.toml"]')
    assert mrnea.load_program(prog).load_robot().links == robot.links


def test_a_program_names_its_wrenches_links(tmp_path) -> None:
    prog = mrnea.load_program(_hold_program(tmp_path, TWO_WRENCHES))
    robot = prog.load_robot()
    prog = prog.on(robot)
    assert set(prog.f_ext) == {"hand_l", "upper_arm_r"}
    assert np.array_equal(prog.f_ext["hand_l"], np.tile(W_L, (prog.K, 1)))
    assert np.array_equal(prog.f_ext_point["hand_l"], P_L) and "upper_arm_r" not in prog.f_ext_point
    # one [wrench] table without 'link' keeps its meaning: the last link
    one = mrnea.load_program(_hold_program(tmp_path, f"[wrench]\ntimes = [0.0]\n"
                                                     f"values = [{W_R}]\n")).on(robot)
    assert one.f_ext.shape == (one.K, 6)
    # ... and with 'link' it is that link's
    named = mrnea.load_program(_hold_program(tmp_path, f'[wrench]\nlink = "hand_r"\n'
                                                       f'times = [0.0]\nvalues = [{W_R}]\n'))
    assert set(named.on(robot).f_ext) == {"hand_r"}


@pytest.mark.parametrize(("wrenches", "words"), [
    (TWO_WRENCHES.replace('"upper_arm_r"', '"upper_arm_x"'),
     ("hold.toml", "[wrench] 'link'", "'upper_arm_x'", "did you mean 'upper_arm_")),
    (TWO_WRENCHES.replace('"upper_arm_r"', '"hand_l"'),
     ("hold.toml", "[[wrench]] 2", "second wrench on link 'hand_l'")),
])
def test_a_wrong_wrench_link_is_one_error_line(tmp_path, wrenches, words) -> None:
    res = mrnea_cli("check", _hold_program(tmp_path, wrenches))
    one_error_line(res, *words)


def test_cli_two_payloads_and_two_wrenches_equal_pinocchio(tmp_path) -> None:
    """``mrnea simulate`` with two --payload options and a program with two [[wrench]] tables,
    holding a pose: each cycle's drive efforts (cycles.csv) equal Pinocchio's rnea at rest with
    the two masses in its model and the two wrenches in its fext."""
    import csv

    prog = _hold_program(tmp_path, TWO_WRENCHES)
    res = mrnea_cli("simulate", prog, "--payload", "0.5@hand_l:0.02,0,0.05", "--payload",
                    "0.3@forearm_r", "--out", tmp_path / "out")
    assert res.returncode == 0, res.stderr
    robot, model = _pin_with_masses([("wrist_l", 0.5, [0.02, 0, 0.05]),
                                     ("elbow_r", 0.3, [0, 0, 0])])
    pc = PinChain(robot, model)
    q = np.array([HOLD.get(j, 0.0) for j in robot.joint_names])
    f_ext = {"hand_l": np.array(W_L), "upper_arm_r": np.array(W_R)}
    fext = _pin_fext(pc, robot, q, f_ext, {"hand_l": np.array(P_L)})
    ref = pc.ours(pin.rnea(model, pc.data, pc.config(q), np.zeros(robot.n), np.zeros(robot.n),
                           fext))
    with open(tmp_path / "out" / "cycles.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) >= 5
    for row in rows:
        tau = np.array([float(row[f"tau_{j} [N m]"]) for j in robot.joint_names])
        assert rel_err(tau, ref) < 1e-10


SWING = Path(__file__).resolve().parents[1] / "examples" / "waist_left_swing.toml"
HEAVY = [0.0, 0.0, 40.0, 0.0, 0.0, 0.0]  # the left hand pushing down on a part, 40 N


def _swing_with_wrenches(folder: Path) -> Path:
    """examples/waist_left_swing.toml with a 40 N push of the left hand (off its frame's
    origin) and a wrench on the right upper arm."""
    import shutil

    shutil.copy(URDF, folder / URDF.name)
    path = folder / "swing.toml"
    path.write_text(SWING.read_text() + f'\n[[wrench]]\nlink = "hand_l"\ntimes = [0.0]\n'
                    f'values = [{HEAVY}]\npoint = {P_L}\n\n[[wrench]]\nlink = "upper_arm_r"\n'
                    f'times = [0.0]\nvalues = [{W_R}]\n')
    return path


def _pin_ratio(pc: PinChain, robot, model, Q: np.ndarray, dt: float, f_ext: dict,
               f_pt: dict) -> float:
    """The largest |effort| / effort limit over a program's rows by Pinocchio's rnea with the
    wrenches: row k at q_k, qd_k (backward difference, from rest) making the next row's
    velocity (0 after the last); the robot has no drive model beyond its effort limits."""
    V = np.vstack([np.zeros((1, robot.n)), np.diff(Q, axis=0) / dt])
    A = (np.vstack([V[1:], np.zeros((1, robot.n))]) - V) / dt
    worst = 0.0
    for q, v, a in zip(Q, V, A, strict=True):
        tau = pc.ours(pin.rnea(model, pc.data, pc.config(q), pc.vel(v), pc.vel(a),
                               _pin_fext(pc, robot, q, f_ext, f_pt)))
        worst = max(worst, float(np.max(np.abs(tau) / robot.effort_limit)))
    return worst


def test_retime_moves_wrenches_on_named_links_with_the_path(tmp_path) -> None:
    """Retimed with the wrenches on two links, the program stays within every effort limit by
    Pinocchio with those wrenches; the timing made without them does not (the push binds)."""
    robot, model, _ = _robot("waist")
    pc = PinChain(robot, model)
    prog = mrnea.load_program(_swing_with_wrenches(tmp_path))
    res = mrnea.retime(robot, prog)
    assert res.achievable and set(res.f_ext) == {"hand_l", "upper_arm_r"}
    M = res.q_cmd.shape[0]
    assert np.array_equal(res.f_ext["hand_l"], np.tile(HEAVY, (M, 1)))
    assert np.array_equal(res.f_ext_point["hand_l"], P_L)
    f_ext, f_pt = {"hand_l": np.array(HEAVY), "upper_arm_r": np.array(W_R)}, {"hand_l": P_L}
    assert _pin_ratio(pc, robot, model, res.q_cmd, res.dt, f_ext, f_pt) <= 1.0 + 1e-9
    bare = mrnea.retime(robot, mrnea.load_program(SWING))
    assert _pin_ratio(pc, robot, model, bare.q_cmd, bare.dt, f_ext, f_pt) > 1.0 + 1e-6
    # the closed-form estimate takes them too (check's suggestion)
    from mrnea.retime import scale_estimate

    on = prog.on(robot)
    assert scale_estimate(robot, on.q_cmd, on.dt, on.f_ext, on.f_ext_point) > 0


def test_cli_retime_writes_each_links_wrench_and_check_follows_it(tmp_path) -> None:
    res = mrnea_cli("retime", _swing_with_wrenches(tmp_path), "--out", tmp_path / "rt",
                    "--no-3d")
    assert res.returncode == 0, res.stderr
    written = sorted((tmp_path / "rt").glob("*.toml"))
    assert len(written) == 1
    text = written[0].read_text()
    assert text.count("[[wrench]]") == 2 and 'link = "hand_l"' in text
    again = mrnea.load_program(written[0]).on(mrnea.load_urdf(URDF))
    assert np.array_equal(again.f_ext["hand_l"], np.tile(HEAVY, (again.K, 1)))
    assert np.array_equal(again.f_ext_point["hand_l"], P_L)
    check = mrnea_cli("check", written[0])
    assert check.returncode == 0, check.stdout + check.stderr
    assert "ACHIEVABLE" in check.stdout


def test_two_wrenches_on_one_link_at_one_point_add(tmp_path) -> None:
    """Two [[wrench]] tables on one link at the same point are their sum at every cycle (each
    linear between its breakpoints, held outside them)."""
    ramp = [0.0, 4.0, 0.0, 0.0, 0.0, 1.0]
    two = (f'[[wrench]]\nlink = "hand_l"\ntimes = [0.0]\nvalues = [{W_L}]\npoint = {P_L}\n\n'
           f'[[wrench]]\nlink = "hand_l"\ntimes = [0.02, 0.04]\n'
           f'values = [[0, 0, 0, 0, 0, 0], {ramp}]\npoint = {P_L}\n')
    prog = mrnea.load_program(_hold_program(tmp_path, two))
    prog = prog.on(prog.load_robot())
    t = prog.t
    share = np.clip((t - 0.02) / 0.02, 0.0, 1.0)[:, None]
    assert np.allclose(prog.f_ext["hand_l"], np.array(W_L) + share * np.array(ramp),
                       rtol=0, atol=1e-12)
    assert np.array_equal(prog.f_ext_point["hand_l"], P_L)


def test_a_sweep_time_scaling_moves_each_links_wrench(tmp_path) -> None:
    """``time_scaled`` (a sweep's ``time_scale``) keeps each link's wrench: a ramp on the left
    hand is stretched with the path (its value at the new rows is the ramp's at the program
    instant they map to), the right arm's constant stays."""
    from mrnea.sweep.timescale import time_scaled

    ramp = ('[[wrench]]\nlink = "hand_l"\ntimes = [0.0, 0.05]\n'
            'values = [[0, 0, 0, 0, 0, 0], [5, 0, 0, 0, 0, 0]]\n\n'
            f'[[wrench]]\nlink = "upper_arm_r"\ntimes = [0.0]\nvalues = [{W_R}]\n')
    prog = mrnea.load_program(_hold_program(tmp_path, ramp))
    prog = prog.on(prog.load_robot())
    slow = time_scaled(prog, 2.0)
    assert set(slow.f_ext) == {"hand_l", "upper_arm_r"}
    assert np.array_equal(slow.f_ext["upper_arm_r"], np.tile(W_R, (slow.K, 1)))
    # program instant of new row k: t_k / 2; the ramp's fx there: 5 min(t_k / 2 / 0.05, 1)
    expected = 5 * np.minimum(slow.t / 2 / 0.05, 1.0)
    assert np.allclose(slow.f_ext["hand_l"][:, 0], expected, rtol=0, atol=1e-12)
