"""Inverse kinematics and Cartesian programs on kinematic trees (issue 25): a tool names its link
(the tip), the joints that carry it move, every other joint holds. Oracle: Pinocchio's frame
placements (``updateFramePlacements``, ``data.oMf``) of the same URDF at the returned q.

Robots: Baxter (example-robot-data: a pan head and two 7-joint arms) and the two-arm torso of
``examples/waist_two_arms.urdf`` (a waist joint carries both 4-joint arms).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import PinChain, erd_path, mrnea_cli, one_error_line, pin_from_urdf

import mrnea
from mrnea.errors import MrneaError, StateError

pin = pytest.importorskip("pinocchio")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PROGRAM = EXAMPLES / "baxter_cartesian.toml"
WAIST = EXAMPLES / "waist_two_arms.urdf"
TIPS = ["head", "left_wrist", "right_wrist"]


def _load(path: Path, tip=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # meshes left out of the 3D view
        robot = mrnea.load_urdf(path, tip=tip)
    return robot, PinChain(robot, pin_from_urdf(path, robot))


@pytest.fixture(scope="module")
def baxter():
    path = erd_path("baxter_description/urdf/baxter.urdf")
    return (path, *_load(path, TIPS))


@pytest.fixture(scope="module")
def waist():
    return _load(WAIST)


def _placement(pc: PinChain, q, frame: str, offset=None) -> np.ndarray:
    """Pinocchio's pose (4, 4) of a frame of the model (a link, or a frame merged into one) at
    our q, times ``offset`` (None: the frame itself)."""
    pin.forwardKinematics(pc.model, pc.data, pc.config(q))
    pin.updateFramePlacements(pc.model, pc.data)
    T = pc.data.oMf[pc.model.getFrameId(frame)].homogeneous
    return T if offset is None else T @ offset


def _moved(robot, q0, q) -> list[str]:
    """The joints whose position changed (names)."""
    return [robot.joint_names[i] for i in np.flatnonzero(q != q0)]


@pytest.mark.parametrize("tool", ["left_gripper", "right_gripper", "right_wrist"])
def test_baxter_ik_reaches_each_arms_pose_by_pinocchio(baxter, tool) -> None:
    _, robot, pc = baxter
    rng = np.random.default_rng(len(tool))
    side = tool.split("_")[0]
    arm = [n for n in robot.joint_names if n.startswith(side)]
    for _ in range(4):
        q_true = rng.uniform(-0.6, 0.6, robot.n)
        target = _placement(pc, q_true, tool)  # reachable by construction, Pinocchio's pose
        q0 = q_true + rng.uniform(-0.15, 0.15, robot.n)
        q = mrnea.inverse_kinematics(robot, target, q0, tool=tool)
        reached = _placement(pc, q, tool)
        assert np.abs(reached[:3, 3] - target[:3, 3]).max() < 1e-10
        assert np.abs(reached[:3, :3] - target[:3, :3]).max() < 1e-9
        # the other arm and the head hold exactly; only this arm's 7 joints move
        assert set(_moved(robot, q0, q)) <= set(arm)
        assert len(_moved(robot, q0, q)) == 7


def test_baxter_ik_holds_named_joints(baxter) -> None:
    _, robot, pc = baxter
    rng = np.random.default_rng(3)
    q_true = rng.uniform(-0.5, 0.5, robot.n)
    q0 = q_true + rng.uniform(-0.1, 0.1, robot.n)
    q_true[robot.joint_names.index("left_w2")] = q0[robot.joint_names.index("left_w2")]
    target = _placement(pc, q_true, "left_gripper")
    q = mrnea.inverse_kinematics(robot, target, q0, tool="left_gripper", hold=["left_w2"])
    assert np.abs(_placement(pc, q, "left_gripper") - target).max() < 1e-9
    moved = _moved(robot, q0, q)
    assert "left_w2" not in moved and len(moved) == 6


def test_waist_moves_for_either_arm_unless_held(waist) -> None:
    """A tool on the left hand: the waist (shared by both arms) moves with the left arm; the
    right arm's joints hold (its hand swings with the waist); held, the waist keeps q0."""
    robot, pc = waist
    tool = {"link": "hand_l", "xyz": [0.05, 0.0, 0.0]}
    offset = np.eye(4)
    offset[:3, 3] = tool["xyz"]
    rng = np.random.default_rng(11)
    w = robot.joint_names.index("waist")
    for hold in ([], ["waist"]):
        q_true = rng.uniform(-0.6, 0.6, robot.n)
        q0 = q_true + rng.uniform(-0.05, 0.05, robot.n)
        if hold:
            q_true[w] = q0[w]  # a pose the arm reaches alone
        target = _placement(pc, q_true, "hand_l", offset)
        q = mrnea.inverse_kinematics(robot, target, q0, tool=tool, hold=hold)
        assert np.abs(_placement(pc, q, "hand_l", offset) - target).max() < 1e-9
        moved = set(_moved(robot, q0, q))
        left = {"shoulder_pitch_l", "shoulder_roll_l", "elbow_l", "wrist_l"}
        assert moved == (left if hold else left | {"waist"})
    # forward kinematics of a tool on a branch: Pinocchio's pose of that link, times the tool
    T = mrnea.forward_kinematics(robot, q0, tool=tool)[-1]
    assert np.abs(T - _placement(pc, q0, "hand_l", offset)).max() < 1e-12


def test_tree_tools_are_checked(waist) -> None:
    robot, _ = waist
    q = np.zeros(robot.n)
    with pytest.raises(StateError, match=r"tool 'hand_x' is no frame of a link of robot"):
        mrnea.forward_kinematics(robot, q, tool="hand_x")
    with pytest.raises(StateError, match=r"tool: 'link': no link named 'hand_x'"):
        mrnea.forward_kinematics(robot, q, tool={"link": "hand_x"})
    with pytest.raises(StateError, match=r"hold: no joint named 'waste'"):
        mrnea.inverse_kinematics(robot, np.eye(4), q, tool="hand_l", hold=["waste"])
    with pytest.raises(StateError, match=r"hold: expected a list of joint names"):
        mrnea.inverse_kinematics(robot, np.eye(4), q, tool="hand_l", hold="waist")


def test_baxter_cartesian_program_by_pinocchio(baxter) -> None:
    """examples/baxter_cartesian.toml: each move's programmed pose is Pinocchio's pose of its
    tool at the commanded q, every cycle; a move of one arm leaves the other arm and the head
    where they are; the tool path has no finding."""
    _, robot, pc = baxter
    prog = mrnea.load_program(PROGRAM, robot=robot)
    path = prog.cartesian
    assert path.achievable, path.findings
    names = robot.joint_names
    q0 = prog.q_cmd[0]
    assert q0[names.index("left_s0")] == 0.3 and q0[names.index("head_pan")] == 0.0
    tools = {1: "left_gripper", 2: "right_gripper", 3: "left_gripper", 4: "right_gripper"}
    for k in range(0, prog.q_cmd.shape[0], 7):
        m = int(path.move[k])
        T = _placement(pc, prog.q_cmd[k], tools[m])
        assert np.abs(T - path.pose[k]).max() < 1e-9, (k, m)
    for m, side in ((1, "left"), (2, "right"), (4, "right")):
        rows = np.flatnonzero(path.move == m)
        moved = np.flatnonzero(np.ptp(prog.q_cmd[max(rows[0] - 1, 0):rows[-1] + 1], axis=0) > 0)
        assert {names[i].split("_")[0] for i in moved} == {side}, (m, moved)
    rows = np.flatnonzero(path.move == 4)
    assert np.ptp(prog.q_cmd[rows, names.index("right_w2")]) == 0.0  # held
    assert np.ptp(prog.q_cmd[rows, names.index("right_w0")]) > 0.0
    rows = np.flatnonzero(path.move == 3)  # the joint move by name: right_w0 alone
    moved = np.flatnonzero(np.ptp(prog.q_cmd[max(rows[0] - 1, 0):rows[-1] + 1], axis=0) > 0)
    assert [names[i] for i in moved] == ["right_w0"]
    assert prog.q_cmd[rows[-1], names.index("right_w0")] == 0.4


@pytest.mark.slow
def test_baxter_cartesian_program_from_the_command_line(baxter, tmp_path) -> None:
    path, _, _ = baxter
    res = mrnea_cli("check", path, PROGRAM)
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("ACHIEVABLE: baxter follows the program"), res.stdout
    out = tmp_path / "retimed"
    res = mrnea_cli("retime", path, PROGRAM, "--out", out)
    assert res.returncode == 0, res.stderr
    # two tools: the joint program is written, no single-tool pose CSV
    assert (out / "retimed.toml").is_file() and not (out / "retimed_poses.csv").exists()


@pytest.mark.parametrize("change, words", [
    (("tool = \"right_gripper\"", "tool = \"right_griper\""), ["[[move]] 2 (linear)",
                                                             "'right_griper'"]),
    (("hold = [\"right_w2\"]", "hold = [\"right_w9\"]"), ["[[move]] 4 (linear)",
                                                        "'right_w9'"]),
    (("hold = [\"right_w2\"]", "hold = \"right_w2\""), ["[[move]] 4 (linear)", "'hold'"]),
    (("target = {right_w0 = 0.4}", "target = {right_wO = 0.4}"), ["[[move]] 3 (joint)",
                                                                 "'right_wO'"]),
    (("tool = \"left_gripper\"", "tool = {xyz = [0, 0, 0.1]}"), ["[program]", "which link"]),
    (("[[move]]                    # the left",
      "[wrench]\ntimes = [0.0]\nvalues = [[0, 0, -10, 0, 0, 0]]\n\n[[move]]  # the left"),
     ["[wrench]", "several tools", "'link'"]),
])
def test_bad_tree_programs_give_one_error_line(baxter, tmp_path, change, words) -> None:
    path, _, _ = baxter
    text = PROGRAM.read_text(encoding="utf-8")
    assert change[0] in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(change[0], change[1], 1), encoding="utf-8")
    with pytest.raises(MrneaError):
        mrnea.load_program(bad, robot=_load(path, TIPS)[0])
    one_error_line(mrnea_cli("check", path, bad), *words)


def test_simulated_tool_errors_by_pinocchio(baxter) -> None:
    """``simulate(..., cartesian=)`` on a tree: each cycle's tool error is that of its move's
    tool, as Pinocchio places it at the simulated q, against the programmed pose."""
    _, robot, pc = baxter
    prog = mrnea.load_program(PROGRAM, robot=robot)
    res = mrnea.simulate(robot, prog.q_cmd, prog.dt, cartesian=prog.cartesian, reactions=False)
    tools = {1: "left_gripper", 2: "right_gripper", 3: "left_gripper", 4: "right_gripper"}
    for k in range(0, prog.q_cmd.shape[0], 11):
        T = _placement(pc, res.q[k], tools[int(prog.cartesian.move[k])])
        gap = np.linalg.norm(T[:3, 3] - prog.cartesian.pose[k, :3, 3])
        assert abs(res.tool_position_error[k] - gap) <= 1e-12 + 1e-9 * gap, k
    assert res.tool_point is None  # several tools: the 3D view traces every branch's tip


WAIST_PROGRAM = """[program]
name = "reach"
robot = "{urdf}"
dt = 0.01
{tool}
q0 = {q0}

[[move]]
type = "linear"
xyz = [0.3, 0.3, 1.2]
speed = 0.2
acceleration = 1.0

[[move]]
type = "joint"
target = {target}
velocity_limit = {vel}
acceleration_limit = 2.0
"""


@pytest.mark.parametrize("keys, words", [
    ({"tool": ""}, ["[program]", "kinematic tree: name the tool"]),
    ({"q0": "{waist = 0.1, elbo_l = 0.3}"}, ["[program] q0", "'elbo_l'", "'elbow_l'"]),
    ({"vel": "{elbow_l = 1.0}"}, ["[[move]] 2 (joint)", "velocity_limit", "'waist'"]),
    ({"target": "[0.2]"}, ["[[move]] 2 (joint) target", "9 joints"]),
    ({"tool": "tool = {link = 5}"}, ["[program]", "'tool.link'"]),
])
def test_bad_waist_programs_give_one_error_line(tmp_path, keys, words) -> None:
    fields = {"urdf": WAIST.as_posix(), "tool": 'tool = "hand_l"', "q0": "{waist = 0.1}",
              "target": "{waist = 0.2}", "vel": "1.0", **keys}
    bad = tmp_path / "bad.toml"
    bad.write_text(WAIST_PROGRAM.format(**fields), encoding="utf-8")
    one_error_line(mrnea_cli("check", bad), *words)
